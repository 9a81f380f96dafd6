// Suggestions for misspelt names, shared by every layer that reports an unknown key, option,
// signal, parameter, channel or variable ("unknown key 'lowpas_hz'; did you mean 'lowpass_hz'?").
#pragma once

#include <string>
#include <vector>

namespace graybox::util {

/// The Levenshtein distance (insertions, deletions and substitutions of single characters).
std::size_t EditDistance(const std::string& a, const std::string& b);

/// The closest of `candidates` to `word` by edit distance, or "" when none is within
/// max(2, |word| / 3) edits (a suggestion far from the word would mislead).
std::string DidYouMean(const std::string& word, const std::vector<std::string>& candidates);

/// "; did you mean 'x'?" when DidYouMean finds a candidate, else "" (to append to a message).
std::string DidYouMeanHint(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace graybox::util
