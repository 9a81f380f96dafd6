// report.html: a DiagnosisReport (diagnose.h) as one self-contained page a person reads in a
// browser — inline CSS and inline SVG figures, no external file, nothing from the network.
//
//   const DiagnosisReport d = Diagnose(problem, splits);
//   WriteFileAtomically(dir + "/report.html", DiagnosisHtml(d, {{"revision", GitRevision()}}));
//
// The page, in order:
//   1. the verdict sentence (DiagnosisReport::verdict), then the nominal and final validation
//      NRMSE with the metric's definition (diagnose.h) and the accepted effects (effect, detail,
//      attachment, NRMSE before -> after, gap closed, LR p-value, parameters with 95 % intervals);
//   2. residual energy by regime: per channel and regime partition of the nominal localisation,
//      energy share vs sample share of each bin; the top-ranked entries of every kind;
//   3. before/after: per used validation split and output channel, measured vs nominal vs final
//      simulation over time, and the residuals before and after;
//   4. the candidates: round 1's score-test statistics (log scale, the chi-square critical value
//      at DiagnoseOptions::significance marked on each row), each round's re-fit table and its
//      decision;
//   5. the residual spectrum: residual and measured-output share per band and channel (nominal
//      and remainder);
//   6. residual autocorrelation and residual-input cross-correlation with their bounds (nominal
//      and remainder);
//   7. the unexplained remainder (brief report, top entries, notes), the stop reason, the timings,
//      the options and the run metadata.
//
// Every figure is a <figure class="figure" data-figure="NAME"> holding one inline <svg> whose
// first child is a <title>; <body data-figure-count="N"> gives their number. Where there is
// nothing to draw (no accepted effect, no regime signal, an empty list) a sentence stands instead
// of the figure. Every text is HTML-escaped; NaN and infinite numbers print as "n/a". A short
// inline script (no network, no external file) marks each <svg> that the browser laid out with a
// non-zero size as data-rendered="ok" and records script errors in <body data-errors="...">, so
// a headless browser's DOM dump shows whether the page rendered (tests/diagnosis).
//
// Failure behaviour: none beyond std::bad_alloc; every field of the report is shown as it is.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "graybox/diagnosis/diagnose.h"

namespace graybox::diagnosis {

/// DIR/report.html: a self-contained page (inline CSS and SVG, no script from the network, no
/// external file) that a person reads in a browser. `run` (command line, revision, seed, ...) is
/// listed in the given order at the end of the page.
std::string DiagnosisHtml(const DiagnosisReport& report,
                          const std::vector<std::pair<std::string, std::string>>& run = {});

}  // namespace graybox::diagnosis
