// report.html (report_html.h): a real diagnosis of a sliding mass with a withheld friction is
// written as report.html and rendered in headless Chromium; the DOM it dumps must hold every figure
// the generator wrote, each <svg> laid out with a non-zero size and no script error. The verdict
// comes first, every accepted effect is named, NaN prints as n/a, every text is escaped, an empty
// report gives sentences instead of figures, and long records stay small (pixel envelopes).
//
// Chromium is required: when it is not found the test FAILS (tools/setup.sh installs Debian's
// chromium; GRAYBOX_CHROMIUM names another binary). GRAYBOX_REPORT_HTML_COPY=FILE keeps a copy of
// the real diagnosis' page to look at.
#include "graybox/diagnosis/report_html.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/diagnosis/diagnose.h"
#include "graybox/estimators/fit/fit.h"
#include "graybox/models/model.h"
#include "slide_truth.h"

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;
namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---- The synthetic problem (slide_truth.h, as diagnose_test.cc, 600 samples per split): a 2 kg
// slide with viscous friction and a withheld friction f(v) = fc (2 / pi) atan(v / vd) + f_asym.
constexpr double kFc = 1.2;    // [N]
constexpr double kAsym = 0.5;  // [N]
constexpr double kVd = 0.001;  // [m/s]

DiagnosisReport RunDiagnosis() {
  std::mt19937 rng(20261126u);
  testing::SlideTruth truth;
  truth.samples = 600;
  truth.friction = [](double v) { return kFc * (2.0 / testing::kPi) * std::atan(v / kVd) + kAsym; };
  const std::vector<est::SplitData> splits = {
      testing::SlideSplit(truth, "estimation", est::SplitRole::kEstimation, 0.0, &rng),
      testing::SlideSplit(truth, "validation", est::SplitRole::kValidation, 0.7, &rng)};
  DiagnoseOptions o;
  // The friction candidates, each re-fitted (coulomb and the two asymmetric_friction variants).
  o.screening.candidates.effects = {"coulomb", "asymmetric_friction", "viscous"};
  o.screening.refit_top = 3;
  o.max_effects = 2;
  return Diagnose(testing::NominalSlideProblem(), splits, o);
}

// ---- Helpers

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

// The value of attribute `name` on the <body> tag; `found` says whether it is there.
std::string BodyAttribute(const std::string& html, const std::string& name, bool* found) {
  const std::size_t body = html.find("<body");
  const std::size_t end = html.find('>', body);
  *found = false;
  if (body == std::string::npos || end == std::string::npos) return "";
  const std::string tag = html.substr(body, end - body);
  const std::string key = " " + name + "=\"";
  const std::size_t p = tag.find(key);
  if (p == std::string::npos) return "";
  *found = true;
  const std::size_t start = p + key.size();
  return tag.substr(start, tag.find('"', start) - start);
}

// The text of <body> with every tag removed and whitespace runs collapsed.
std::string BodyText(const std::string& html) {
  std::size_t p = html.find("<body");
  p = html.find('>', p) + 1;
  std::string out;
  bool in_tag = false, space = false;
  for (; p < html.size(); ++p) {
    const char c = html[p];
    if (c == '<') in_tag = true;
    if (!in_tag) {
      if (std::isspace(static_cast<unsigned char>(c))) {
        space = !out.empty();
      } else {
        if (space) out += ' ';
        space = false;
        out += c;
      }
    }
    if (c == '>') in_tag = false;
  }
  return out;
}

// Escaping of text nodes as the page writes them (& < > " ') and as a DOM dump serialises them
// (& < > only).
std::string EscapeText(const std::string& s, bool quotes) {
  std::string out;
  for (char c : s) {
    if (c == '&') {
      out += "&amp;";
    } else if (c == '<') {
      out += "&lt;";
    } else if (c == '>') {
      out += "&gt;";
    } else if (quotes && c == '"') {
      out += "&quot;";
    } else if (quotes && c == '\'') {
      out += "&#39;";
    } else {
      out += c;
    }
  }
  return out;
}

// Words "nan", "inf", "infinity" (any case): a number printed without the n/a guard.
std::vector<std::string> NonFiniteWords(const std::string& html) {
  std::vector<std::string> bad;
  std::string word;
  for (std::size_t i = 0; i <= html.size(); ++i) {
    const char c = i < html.size() ? html[i] : ' ';
    if (std::isalpha(static_cast<unsigned char>(c))) {
      word += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      continue;
    }
    if (word == "nan" || word == "inf" || word == "infinity") {
      bad.push_back(html.substr(i > 40 ? i - 40 : 0, 60));
    }
    word.clear();
  }
  return bad;
}

std::string FindChromium() {
  if (const char* env = std::getenv("GRAYBOX_CHROMIUM"); env != nullptr && *env) return env;
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    for (const char* name : {"chromium", "chromium-browser", "google-chrome", "chrome"}) {
      const fs::path p = fs::path(dir) / name;
      if (::access(p.c_str(), X_OK) == 0) return p.string();
    }
  }
  return "";
}

// A fresh folder under the temporary directory.
fs::path TempDir(const std::string& tag) {
  const fs::path dir =
      fs::temp_directory_path() / ("graybox_report_html_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Renders `html_file` in headless Chromium and returns the DOM it dumps; fails the test (with
// the browser's log) when Chromium is missing or exits with an error.
std::string RenderInChromium(const fs::path& html_file) {
  const std::string chromium = FindChromium();
  if (chromium.empty()) {
    ADD_FAILURE() << "chromium not found on PATH: report.html cannot be rendered. Install "
                     "Debian's chromium (tools/setup.sh installs it) or set GRAYBOX_CHROMIUM to "
                     "a Chromium or Chrome binary.";
    return "";
  }
  const fs::path dir = html_file.parent_path();
  const fs::path dom = dir / "dom.html", log = dir / "chromium.log";
  const std::string command =
      "timeout 120 \"" + chromium +
      "\" --headless --disable-gpu --no-sandbox --disable-dev-shm-usage --no-first-run "
      "--disable-extensions --user-data-dir=\"" +
      (dir / "profile").string() + "\" --virtual-time-budget=5000 --dump-dom \"file://" +
      html_file.string() + "\" > \"" + dom.string() + "\" 2> \"" + log.string() + "\"";
  const auto start = std::chrono::steady_clock::now();
  const int rc = std::system(command.c_str());
  std::cout << "chromium: "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
            << " s\n";
  if (rc != 0) {
    ADD_FAILURE() << "chromium failed (status " << rc << "): " << command << "\n" << ReadFile(log);
    return "";
  }
  std::string out = ReadFile(dom);
  if (out.find("<body") == std::string::npos) {
    ADD_FAILURE() << "chromium dumped no DOM: " << command << "\n" << ReadFile(log);
  }
  return out;
}

// The figures the generator must write for `d` (see report_html.h), counted from the report.
int ExpectedFigures(const DiagnosisReport& d) {
  const Localization& nom = d.nominal_localization;
  int n = 0;
  for (const ChannelResidual& c : nom.channels) {
    std::vector<std::string> partitions;
    for (const LocalizationEntry& e : nom.Entries("regime", c.name)) {
      if (std::find(partitions.begin(), partitions.end(), e.partition) == partitions.end()) {
        partitions.push_back(e.partition);
      }
    }
    n += static_cast<int>(partitions.size());
  }
  for (const std::string& split : nom.splits) {
    for (const est::SplitEvaluation& e : d.nominal.evaluations) {
      if (e.name == split) n += 2 * static_cast<int>(e.measured.cols());
    }
  }
  if (!d.rounds.empty() && !d.rounds.front().screening.screened.empty()) ++n;
  auto band_channels = [](const Localization& loc) {
    int k = 0;
    for (const ChannelResidual& c : loc.channels) {
      for (const BandEnergy& b : loc.bands) {
        if (b.channel == c.name) {
          ++k;
          break;
        }
      }
    }
    return k;
  };
  n += band_channels(nom);
  if (!d.accepted.empty()) n += band_channels(d.remainder);
  n += static_cast<int>(nom.whiteness.size() + nom.cross_correlations.size());
  return n;
}

// The checks on a DOM dump of a page that wrote `figures` figures.
void ExpectRendered(const std::string& page, const std::string& dom, int figures) {
  bool found = false;
  const std::string errors = BodyAttribute(dom, "data-errors", &found);
  EXPECT_TRUE(found) << "the page's script did not run (no data-errors on <body>)";
  EXPECT_EQ(errors, "") << "script errors in the page";
  EXPECT_EQ(BodyAttribute(dom, "data-figure-count", &found), std::to_string(figures));
  EXPECT_EQ(Count(dom, " data-figure=\""), figures);
  EXPECT_EQ(Count(dom, "<figure class=\"figure\""), figures);
  const int svgs = Count(page, "<svg ");
  EXPECT_EQ(svgs, figures) << "one <svg> per figure";
  EXPECT_EQ(Count(dom, "<svg "), svgs);
  EXPECT_EQ(BodyAttribute(dom, "data-svg-count", &found), std::to_string(svgs));
  EXPECT_EQ(BodyAttribute(dom, "data-svg-rendered", &found), std::to_string(svgs))
      << "an <svg> was laid out with zero size";
  EXPECT_EQ(Count(dom, "data-rendered=\"ok\""), svgs);
  // Each <svg>'s first child is its <title>.
  const std::regex titled("<svg [^>]*><title>[^<]+</title>");
  EXPECT_EQ(
      std::distance(std::sregex_iterator(page.begin(), page.end(), titled), std::sregex_iterator()),
      svgs);
}

// ---- Tests

TEST(DiagnosisHtml, RealDiagnosisRendersInHeadlessChromium) {
  const auto start = std::chrono::steady_clock::now();
  const DiagnosisReport d = RunDiagnosis();
  std::cout << d.BriefReport() << "\n"
            << "diagnosis: "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
            << " s\n";
  ASSERT_FALSE(d.accepted.empty()) << d.FullReport();
  ASSERT_FALSE(d.verdict.empty());

  const std::string page = DiagnosisHtml(d, {{"command", "graybox diagnose slide <test>"}});
  const fs::path dir = TempDir("real");
  const fs::path file = dir / "report.html";
  std::ofstream(file, std::ios::binary) << page;
  if (const char* keep = std::getenv("GRAYBOX_REPORT_HTML_COPY"); keep != nullptr && *keep) {
    std::ofstream(keep, std::ios::binary) << page;  // to look at the page in a browser
  }
  std::cout << "report.html: " << page.size() << " bytes, " << Count(page, " data-figure=\"")
            << " figures (" << file << ")\n";

  // Self-contained: no external reference.
  const std::string no_svg_ns = std::regex_replace(page, std::regex("xmlns=\"[^\"]*\""), "");
  for (const char* external :
       {"http://", "https://", " src=", " href=\"http", "<link", "@import", "url("}) {
    EXPECT_EQ(no_svg_ns.find(external), std::string::npos) << external;
  }
  // The figures: those the report calls for, each named.
  const int figures = ExpectedFigures(d);
  EXPECT_GE(figures, 8);
  EXPECT_EQ(Count(page, " data-figure=\""), figures);
  EXPECT_NE(page.find("data-figure=\"screening:round 1\""), std::string::npos);
  EXPECT_NE(page.find("data-figure=\"overlay:validation:load.qd\""), std::string::npos);
  EXPECT_NE(page.find("data-figure=\"residual:validation:load.qd\""), std::string::npos);
  EXPECT_NE(page.find("data-figure=\"spectrum:remainder:load.qd\""), std::string::npos);
  EXPECT_NE(page.find("data-figure=\"autocorrelation:load.qd\""), std::string::npos);
  EXPECT_NE(page.find("data-figure=\"crosscorrelation:load.qd:force\""), std::string::npos);
  EXPECT_NE(page.find("data-figure=\"regime:load.qd:"), std::string::npos);

  // The verdict is the first text of <body>; the metric is named as in diagnose.h.
  EXPECT_EQ(BodyText(page).rfind(EscapeText(d.verdict, true), 0), 0u)
      << BodyText(page).substr(0, 300);
  EXPECT_NE(page.find("validation NRMSE: nominal"), std::string::npos);
  EXPECT_NE(page.find("of the mean over the output channels of NRMSE = RMSE / std(measured "
                      "channel)"),
            std::string::npos);
  // Every accepted effect is named in the accepted-effects table.
  const std::size_t table = page.find("<div id=\"accepted\">");
  ASSERT_NE(table, std::string::npos);
  const std::string accepted = page.substr(table, page.find("</div>", table) - table);
  for (const AcceptedEffect& a : d.accepted) {
    EXPECT_NE(accepted.find("<b>" + EscapeText(a.effect, true) + "</b>"), std::string::npos)
        << a.effect;
  }
  EXPECT_NE(page.find("graybox diagnose slide &lt;test&gt;"), std::string::npos);
  EXPECT_TRUE(NonFiniteWords(page).empty()) << NonFiniteWords(page).front();

  // Rendered by the browser: every figure, every <svg> with a size, no error.
  const std::string dom = RenderInChromium(file);
  if (!dom.empty()) {
    ExpectRendered(page, dom, figures);
    EXPECT_EQ(BodyText(dom).rfind(EscapeText(d.verdict, false), 0), 0u);
  }

  // NaN prints as n/a (a parameter without an interval, an undefined band ratio, a NaN metric).
  DiagnosisReport n = d;
  n.accepted.front().parameters.front().ci_low = kNaN;
  n.accepted.front().parameters.front().ci_high = kNaN;
  n.final_validation_nrmse = kNaN;
  n.remaining_fraction = kNaN;
  ASSERT_FALSE(n.nominal_localization.bands.empty());
  n.nominal_localization.bands.front().power_ratio = kNaN;
  n.nominal_localization.whiteness.front().correlation[3] = kNaN;
  const std::string nan_page = DiagnosisHtml(n);
  EXPECT_NE(nan_page.find("final n/a (n/a of the nominal error remains)"), std::string::npos);
  EXPECT_NE(nan_page.find("95 % [n/a, n/a]"), std::string::npos);
  EXPECT_NE(nan_page.find("(ratio n/a)"), std::string::npos);
  EXPECT_TRUE(NonFiniteWords(nan_page).empty()) << NonFiniteWords(nan_page).front();

  // No accepted effect: a sentence instead of the table, no remainder spectrum.
  DiagnosisReport none = d;
  none.accepted.clear();
  none.stop_reason = "best re-fit viscous: validation NRMSE gain 0.40 % < 2 %";
  const std::string none_page = DiagnosisHtml(none);
  EXPECT_NE(none_page.find("No effect was accepted: best re-fit viscous"), std::string::npos);
  EXPECT_EQ(none_page.find("<div id=\"accepted\">"), std::string::npos);
  EXPECT_EQ(none_page.find("data-figure=\"spectrum:remainder"), std::string::npos);
  EXPECT_EQ(Count(none_page, " data-figure=\""), ExpectedFigures(none));

  if (!HasFailure()) fs::remove_all(dir);
  std::cout << "total: "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
            << " s\n";
}

TEST(DiagnosisHtml, EmptyReportRendersSentencesInsteadOfFigures) {
  const DiagnosisReport d;
  const std::string page = DiagnosisHtml(d);
  EXPECT_EQ(Count(page, " data-figure=\""), 0);
  EXPECT_NE(page.find("data-figure-count=\"0\""), std::string::npos);
  EXPECT_EQ(BodyText(page).rfind("No verdict was given.", 0), 0u);
  for (const char* sentence :
       {"No effect was accepted.", "No selection round was run.",
        "No validation split was evaluated: nothing to overlay.", "No regime partition",
        "No frequency band was computed for the nominal residual.", "No correlation was computed.",
        "No run metadata was given.", "No timing was recorded."}) {
    EXPECT_NE(page.find(sentence), std::string::npos) << sentence;
  }
  EXPECT_TRUE(NonFiniteWords(page).empty()) << NonFiniteWords(page).front();
  const fs::path dir = TempDir("empty");
  std::ofstream(dir / "report.html", std::ios::binary) << page;
  const std::string dom = RenderInChromium(dir / "report.html");
  if (!dom.empty()) ExpectRendered(page, dom, 0);
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(DiagnosisHtml, LongRecordsAreDrawnAsPixelEnvelopes) {
  // Two channels of a 25000-sample test split: each line keeps at most four points per pixel
  // column of the plot (900 px wide), so the page stays small whatever the record length.
  constexpr int kLong = 25000;
  est::SplitEvaluation e;
  e.name = "test";
  e.role = est::SplitRole::kTest;
  e.time = Eigen::VectorXd::LinSpaced(kLong, 0.0, 0.001 * (kLong - 1));
  e.measured.resize(kLong, 2);
  for (int k = 0; k < kLong; ++k) {
    e.measured(k, 0) = std::sin(0.01 * k) + 0.1 * std::sin(1.3 * k);
    e.measured(k, 1) = std::cos(0.003 * k);
  }
  e.simulated = 0.9 * e.measured;
  e.simulated(100, 0) = kNaN;  // a gap in the line
  DiagnosisReport d;
  d.validation_role = "test";
  d.nominal.evaluations = {e};
  d.final_fit.evaluations = {e};
  d.final_fit.evaluations[0].simulated = 0.99 * e.measured;
  d.accepted.push_back(AcceptedEffect{});
  d.accepted[0].effect = "coulomb";
  d.nominal_localization.splits = {"test"};
  d.nominal_localization.channels.push_back({"y1", "m", 1.0, 1.0, 0.5, 0.1});
  d.nominal_localization.channels.push_back({"y2", "m", 1.0, 1.0, 0.5, 0.1});
  const std::string page = DiagnosisHtml(d);
  std::cout << "report.html with 2 x 25000 samples: " << page.size() << " bytes\n";
  EXPECT_EQ(Count(page, " data-figure=\"overlay:test:"), 2);
  EXPECT_EQ(Count(page, " data-figure=\"residual:test:"), 2);
  // 4 figures x at most 3 lines (one more piece for the gap) x 4 points x 800 columns x ~12 bytes.
  constexpr std::size_t kMaxBytes = 800000;
  EXPECT_LT(page.size(), kMaxBytes);
  EXPECT_TRUE(NonFiniteWords(page).empty()) << NonFiniteWords(page).front();
}

TEST(DiagnosisHtml, EscapesEveryTextAndPrintsNaNAsNa) {
  DiagnosisReport d;
  d.problem = "a<b>&\"c\"";
  d.verdict = "the gap lies in <script>alert('x')</script> & more";
  d.validation_role = "validation";
  d.nominal_validation_nrmse = kNaN;
  d.final_validation_nrmse = 0.5;
  d.stop_reason = "p = 0.3 >= 0.01";
  Localization& loc = d.nominal_localization;
  loc.splits = {"val<1>"};
  loc.channels.push_back({"y<0>", "m/s", 1.0, 2.0, 1.0, kNaN});
  LocalizationEntry e;
  e.channel = "y<0>";
  e.kind = "regime";
  e.partition = "v<speed>";
  e.label = "v in [\"a\", 'b'] & <near zero>";
  e.energy_share = kNaN;
  e.sample_share = 0.5;
  e.lower = kNaN;
  loc.entries.push_back(e);
  loc.bands.push_back({"y<0>", 0.1, 1.0, 0.7, kNaN, kNaN, 3});
  Whiteness w;
  w.channel = "y<0>";
  w.correlation = {0.5, kNaN, 0.1};
  w.bound = 0.05;
  loc.whiteness.push_back(w);
  d.remainder = loc;
  const std::string page = DiagnosisHtml(d, {{"k<1>", "v&2"}});
  EXPECT_EQ(page.find("<script>alert"), std::string::npos);
  EXPECT_EQ(page.find("y<0>"), std::string::npos);
  EXPECT_EQ(page.find("v<speed>"), std::string::npos);
  EXPECT_EQ(page.find("<near zero>"), std::string::npos);
  EXPECT_NE(page.find("&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; more"),
            std::string::npos);
  EXPECT_NE(page.find("a&lt;b&gt;&amp;&quot;c&quot;"), std::string::npos);
  EXPECT_NE(page.find("k&lt;1&gt;"), std::string::npos);
  EXPECT_NE(page.find("v&amp;2"), std::string::npos);
  EXPECT_NE(page.find("p = 0.3 &gt;= 0.01"), std::string::npos);
  EXPECT_NE(page.find("validation NRMSE: nominal n/a, final 0.5"), std::string::npos);
  EXPECT_TRUE(NonFiniteWords(page).empty()) << NonFiniteWords(page).front();
  // Regime chart, spectrum chart and autocorrelation chart, all from hand-made entries.
  EXPECT_EQ(Count(page, " data-figure=\""), 3);
}

}  // namespace
}  // namespace graybox::diagnosis
