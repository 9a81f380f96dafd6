// report.html: the diagnosis as one self-contained page (inline CSS, inline SVG from svg_chart.h,
// a short inline script that marks the laid-out figures).
#include "graybox/diagnosis/report_html.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "svg_chart.h"

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;
using svg::Escape;
using svg::Format;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kTopEntries = 12;
const char* const kMeasuredColor = "#222222";
const char* const kNominalColor = "#d62728";
const char* const kFinalColor = "#2ca02c";
const char* const kSampleColor = "#a0a0a0";
const char* const kOutputColor = "#1f77b4";

const char* const kStyle = R"(
body { font-family: sans-serif; max-width: 1000px; margin: 1.5em auto; padding: 0 1em;
       color: #222; line-height: 1.4; }
.verdict { font-size: 1.6em; font-weight: 600; line-height: 1.3; margin: 0.3em 0 0.6em; }
.subtitle { color: #555; }
h2 { border-bottom: 1px solid #ccc; margin-top: 2em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 3px 6px; text-align: left; vertical-align: top; }
th { background: #f2f2f2; }
.params { overflow-wrap: anywhere; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
.figure { margin: 1em 0; }
.figure svg { max-width: 100%; height: auto; display: block; }
figcaption { color: #555; font-size: 0.9em; }
.metric { font-size: 1.15em; }
.definition, .note { color: #555; font-size: 0.9em; }
nav a { margin-right: 1em; }
)";

// Records script errors on <body data-errors> and marks every <svg> the browser laid out with a
// non-zero size (data-rendered="ok"); no network, no external file.
const char* const kScript = R"(
(function () {
  var errors = [];
  function show() { if (document.body) document.body.setAttribute('data-errors', errors.join(' | ')); }
  window.addEventListener('error', function (e) { errors.push(String(e.message || 'error')); show(); });
  window.addEventListener('unhandledrejection', function (e) { errors.push('rejection: ' + e.reason); show(); });
  window.addEventListener('load', function () {
    var charts = document.querySelectorAll('svg'), ok = 0;
    for (var i = 0; i < charts.length; ++i) {
      var r = charts[i].getBoundingClientRect();
      if (r.width > 0 && r.height > 0) { charts[i].setAttribute('data-rendered', 'ok'); ++ok; }
    }
    document.body.setAttribute('data-svg-count', String(charts.length));
    document.body.setAttribute('data-svg-rendered', String(ok));
    show();
  });
})();
)";

// `s` with the words nan, inf and infinity (any case, with a sign) replaced by "n/a": sentences
// of other reports (BriefReport, reasons, labels) print a NaN as printf does.
std::string NonFiniteAsNa(const std::string& s) {
  std::string out;
  std::size_t i = 0;
  auto word_char = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.';
  };
  while (i < s.size()) {
    if (!std::isalpha(static_cast<unsigned char>(s[i])) || (i > 0 && word_char(s[i - 1]))) {
      out += s[i++];
      continue;
    }
    std::size_t end = i;
    while (end < s.size() && word_char(s[end])) ++end;
    std::string word = s.substr(i, end - i);
    for (char& c : word) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (word == "nan" || word == "inf" || word == "infinity") {
      if (!out.empty() && (out.back() == '-' || out.back() == '+')) out.pop_back();
      out += "n/a";
    } else {
      out += s.substr(i, end - i);
    }
    i = end;
  }
  return out;
}

// Escaped text of another report's sentence.
std::string Text(const std::string& s) { return Escape(NonFiniteAsNa(s)); }

std::string Pct(double share, const char* format = "%.1f") {
  return std::isfinite(share) ? Format(100.0 * share, format) + " %" : "n/a";
}

std::string Join(const std::vector<std::string>& items, const std::string& separator) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) out += (i ? separator : "") + items[i];
  return out;
}

// A table whose cells are already HTML (escaped text); cells starting with '\x01' are numeric.
class Table {
 public:
  explicit Table(std::vector<std::string> header) : header_(std::move(header)) {}
  void Row(std::vector<std::string> cells) { rows_.push_back(std::move(cells)); }
  static std::string Num(const std::string& text) { return "\x01" + text; }
  bool empty() const { return rows_.empty(); }
  std::string Html() const {
    std::ostringstream o;
    o << "<table><thead><tr>";
    for (const std::string& h : header_) o << "<th>" << Escape(h) << "</th>";
    o << "</tr></thead><tbody>\n";
    for (const auto& row : rows_) {
      o << "<tr>";
      for (const std::string& c : row) {
        if (!c.empty() && c[0] == '\x01') {
          o << "<td class=\"num\">" << c.substr(1) << "</td>";
        } else {
          o << "<td>" << c << "</td>";
        }
      }
      o << "</tr>\n";
    }
    o << "</tbody></table>\n";
    return o.str();
  }

 private:
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

class Page {
 public:
  std::ostringstream body;
  int figures = 0;

  void Heading(const std::string& id, const std::string& text) {
    body << "<h2 id=\"" << Escape(id) << "\">" << Escape(text) << "</h2>\n";
  }
  void Sub(const std::string& text) { body << "<h3>" << Escape(text) << "</h3>\n"; }
  void Para(const std::string& text, const std::string& cls = "") {
    body << "<p" << (cls.empty() ? "" : " class=\"" + cls + "\"") << ">" << Text(text) << "</p>\n";
  }
  void Figure(const std::string& name, const std::string& svg_element, const std::string& caption) {
    ++figures;
    body << "<figure class=\"figure\" data-figure=\"" << Escape(name) << "\">" << svg_element;
    if (!caption.empty()) body << "<figcaption>" << Escape(caption) << "</figcaption>";
    body << "</figure>\n";
  }
};

std::string ParameterText(const est::FitParameter& p) {
  std::string s = p.name + " = " + Format(p.value);
  if (!p.unit.empty()) s += " " + p.unit;
  s += ", 95 % [" + Format(p.ci_low) + ", " + Format(p.ci_high) + "]";
  if (p.at_bound) s += " (at a bound)";
  return s;
}

std::string ParametersHtml(const std::vector<est::FitParameter>& parameters) {
  std::vector<std::string> lines;
  for (const est::FitParameter& p : parameters) lines.push_back(Escape(ParameterText(p)));
  return "<span class=\"params\">" + (lines.empty() ? "none" : Join(lines, "<br>")) + "</span>";
}

// The chi-square quantile: x with ChiSquareSurvival(x, dof) = alpha (bisection).
double ChiSquareCritical(double alpha, int dof) {
  if (!(alpha > 0.0 && alpha < 1.0) || dof < 1) return kNaN;
  double lo = 0.0, hi = std::max(1.0, 2.0 * dof);
  while (ChiSquareSurvival(hi, dof) > alpha && hi < 1e8) hi *= 2.0;
  for (int i = 0; i < 200 && hi - lo > 1e-10 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (ChiSquareSurvival(mid, dof) > alpha ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

std::vector<double> ToVector(const Eigen::VectorXd& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}

std::vector<double> Column(const Eigen::MatrixXd& m, int j) {
  std::vector<double> out(static_cast<std::size_t>(m.rows()));
  for (Eigen::Index k = 0; k < m.rows(); ++k) out[static_cast<std::size_t>(k)] = m(k, j);
  return out;
}

const est::SplitEvaluation* FindEvaluation(const est::FitResult& fit, const std::string& name) {
  for (const est::SplitEvaluation& e : fit.evaluations) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

std::string WithUnit(const std::string& name, const std::string& unit) {
  return unit.empty() ? name : name + " [" + unit + "]";
}

// The name and unit of output channel j from the localisation or the evaluation's metrics.
std::pair<std::string, std::string> Channel(const est::SplitEvaluation& e, const Localization& loc,
                                            int j) {
  const std::size_t u = static_cast<std::size_t>(j);
  if (u < loc.channels.size()) return {loc.channels[u].name, loc.channels[u].unit};
  if (u < e.simulation.channels.size()) {
    return {e.simulation.channels[u].name, e.simulation.channels[u].unit};
  }
  return {"output " + std::to_string(j + 1), ""};
}

std::vector<std::string> ChannelNames(const Localization& loc) {
  std::vector<std::string> names;
  for (const ChannelResidual& c : loc.channels) names.push_back(c.name);
  return names;
}

void EntriesTable(Page* page, const std::vector<LocalizationEntry>& entries) {
  if (entries.empty()) {
    page->Para("There is no localisation entry.");
    return;
  }
  Table t({"rank", "channel", "kind", "partition", "piece", "energy share", "sample share",
           "concentration", "score"});
  const std::size_t n = std::min<std::size_t>(entries.size(), kTopEntries);
  for (std::size_t i = 0; i < n; ++i) {
    const LocalizationEntry& e = entries[i];
    t.Row({Table::Num(std::to_string(i + 1)), Escape(e.channel), Escape(e.kind),
           Escape(e.partition), Text(e.label), Table::Num(Pct(e.energy_share)),
           Table::Num(Pct(e.sample_share)), Table::Num("x" + Format(e.concentration, "%.3g")),
           Table::Num(Format(e.score, "%.3g"))});
  }
  page->body << t.Html();
  if (entries.size() > n) {
    page->Para("The " + std::to_string(n) + " best of " + std::to_string(entries.size()) +
                   " entries, ranked by score = energy share x ln(concentration).",
               "note");
  }
}

// 1. The verdict, the validation NRMSE and the accepted effects.
void Summary(Page* page, const DiagnosisReport& d) {
  page->body << "<p class=\"verdict\">"
             << Text(d.verdict.empty() ? "No verdict was given." : d.verdict) << "</p>\n";
  if (!d.nominal_integration_warning.empty()) {
    page->Para("Warning, nominal fit: " + d.nominal_integration_warning + ".", "note");
  }
  page->Para("graybox diagnosis of problem '" + d.problem +
                 "'; validation role: " + (d.validation_role.empty() ? "n/a" : d.validation_role) +
                 "; " + std::to_string(d.accepted.size()) + " effect(s) accepted in " +
                 std::to_string(d.rounds.size()) + " round(s).",
             "subtitle");
  page->body << "<nav><a href=\"#summary\">summary</a><a href=\"#regimes\">regimes</a>"
             << "<a href=\"#overlays\">before/after</a><a href=\"#candidates\">candidates</a>"
             << "<a href=\"#spectrum\">spectrum</a><a href=\"#correlation\">correlation</a>"
             << "<a href=\"#remainder\">remainder</a></nav>\n";
  page->Heading("summary", "Validation error and accepted effects");
  page->Para("validation NRMSE: nominal " + Format(d.nominal_validation_nrmse) + ", final " +
                 Format(d.final_validation_nrmse) + " (" + Pct(d.remaining_fraction) +
                 " of the nominal error remains).",
             "metric");
  page->Para(d.reference.BriefReport() + "; gap = nominal - reference = " + Format(d.gap) + ".",
             "metric");
  const std::vector<std::string>& used = d.nominal_localization.splits;
  page->Para("validation NRMSE = the mean over the validation splits (role " +
                 (d.validation_role.empty() ? std::string("n/a") : d.validation_role) +
                 (used.empty() ? std::string() : "; used: " + Join(used, ", ")) +
                 ") of the mean over the output channels of NRMSE = RMSE / std(measured channel) "
                 "of the free-run simulation from the split's initial state. Share of the error = "
                 "(NRMSE before - NRMSE after) / nominal NRMSE (the noise floor stays in the "
                 "denominator); gap closed = (NRMSE before - NRMSE after) / gap, where the gap is "
                 "what the flexible reference (networks adding a learned force on every axis) "
                 "removes from the nominal NRMSE; above 100 % the effect does better than the "
                 "reference.",
             "definition");
  if (d.accepted.empty()) {
    page->Para("No effect was accepted" +
               (d.stop_reason.empty() ? std::string(".") : ": " + d.stop_reason + "."));
    return;
  }
  Table t({"round", "effect", "detail", "attachment", "validation NRMSE before -> after",
           "share of the error", "gap closed", "LR statistic (dof)", "LR p-value",
           "parameters (95 % interval)"});
  for (const AcceptedEffect& a : d.accepted) {
    t.Row({Table::Num(std::to_string(a.round)), "<b>" + Escape(a.effect) + "</b>", Escape(a.detail),
           Escape(a.attachment),
           Table::Num(Format(a.validation_nrmse_before) + " -&gt; " +
                      Format(a.validation_nrmse_after)),
           Table::Num(Pct(a.error_share)), Table::Num(Pct(a.gap_closed)),
           Table::Num(Format(a.lr_statistic, "%.4g") + " (" + std::to_string(a.dof) + ")"),
           Table::Num(Format(a.lr_p_value, "%.3g")), ParametersHtml(a.parameters)});
  }
  page->body << "<div id=\"accepted\">" << t.Html() << "</div>\n";
}

// 2. Residual energy by regime, and the top-ranked entries.
void Regimes(Page* page, const DiagnosisReport& d) {
  const Localization& loc = d.nominal_localization;
  page->Heading("regimes", "Residual energy by regime (nominal model)");
  page->Para(
      "Each output channel's residual energy (the squared residual in units of the "
      "measured channel's std) is split by the bins of the model's regime signals along the "
      "simulated trajectory. A bin whose energy share exceeds its sample share concentrates "
      "the error there.",
      "definition");
  if (!loc.channels.empty()) {
    Table t({"channel", "std of measured", "energy share", "NRMSE"});
    for (const ChannelResidual& c : loc.channels) {
      t.Row({Escape(WithUnit(c.name, c.unit)), Table::Num(Format(c.scale)),
             Table::Num(Pct(c.energy_share)), Table::Num(Format(c.nrmse))});
    }
    page->body << t.Html();
  }
  int charts = 0;
  for (const std::string& channel : ChannelNames(loc)) {
    std::vector<LocalizationEntry> entries = loc.Entries("regime", channel);
    std::vector<std::string> partitions;
    for (const LocalizationEntry& e : entries) {  // most telling partition first
      if (std::find(partitions.begin(), partitions.end(), e.partition) == partitions.end()) {
        partitions.push_back(e.partition);
      }
    }
    for (const std::string& partition : partitions) {
      std::vector<LocalizationEntry> bins;
      for (const LocalizationEntry& e : entries) {
        if (e.partition == partition) bins.push_back(e);
      }
      // Bins in value order; those without a range (reversal, near zero) first, as ranked.
      std::stable_sort(bins.begin(), bins.end(), [](const auto& a, const auto& b) {
        const bool fa = std::isfinite(a.lower), fb = std::isfinite(b.lower);
        if (fa != fb) return !fa;
        return fa && a.lower < b.lower;
      });
      svg::BarChart c;
      c.title = channel + ": residual energy by " + partition;
      c.value_label = "share";
      c.series_labels = {"residual energy share", "sample share"};
      c.colors = {kNominalColor, kSampleColor};
      c.percent = true;
      for (const LocalizationEntry& e : bins) {
        c.rows.push_back({e.label, {e.energy_share, e.sample_share}, kNaN});
      }
      page->Figure("regime:" + channel + ":" + partition, svg::RenderBarChart(c),
                   "Energy share vs sample share of each bin of " + partition + " (channel " +
                       channel + ").");
      ++charts;
    }
  }
  if (charts == 0) {
    page->Para(
        "No regime partition: the model has no velocity, position, acceleration, force "
        "or pressure signal that varies" +
        (loc.notes.empty() ? std::string(".") : " (" + Join(loc.notes, "; ") + ")."));
  }
  page->Sub("Top-ranked pieces of the residual (all kinds)");
  EntriesTable(page, loc.entries);
}

// 3. Measured vs nominal vs final simulation, and the residuals before and after.
void Overlays(Page* page, const DiagnosisReport& d) {
  page->Heading("overlays", "Before and after, on the validation splits");
  std::vector<std::string> splits = d.nominal_localization.splits;
  if (splits.empty()) {
    for (const est::SplitEvaluation& e : d.nominal.evaluations) {
      if (d.validation_role == "all" || d.validation_role == est::SplitRoleName(e.role)) {
        splits.push_back(e.name);
      }
    }
  }
  const bool has_final = !d.accepted.empty();
  page->Para(has_final ? "Measured output, the nominal model's simulation (red) and the final "
                         "model's (green, with every accepted effect), then the residuals "
                         "measured - simulated of both."
                       : "Measured output and the nominal model's simulation (no effect was "
                         "accepted: the final model is the nominal one), then the residual.",
             "definition");
  int charts = 0;
  for (const std::string& name : splits) {
    const est::SplitEvaluation* nominal = FindEvaluation(d.nominal, name);
    const est::SplitEvaluation* after_eval =
        has_final ? FindEvaluation(d.final_fit, name) : nullptr;
    if (nominal == nullptr) continue;
    const std::vector<double> t = ToVector(nominal->time);
    for (int j = 0; j < nominal->measured.cols(); ++j) {
      const auto [channel_name, unit] = Channel(*nominal, d.nominal_localization, j);
      const std::string channel = WithUnit(channel_name, unit);
      const std::size_t ju = static_cast<std::size_t>(j);
      std::string caption =
          "Split '" + name + "', " + channel + ": NRMSE nominal " +
          (ju < nominal->simulation.channels.size() ? Format(nominal->simulation.channels[ju].nrmse)
                                                    : std::string("n/a"));
      svg::LineChart overlay;
      overlay.title = "split '" + name + "': " + channel;
      overlay.x_label = "time [s]";
      overlay.y_label = channel;
      overlay.series.push_back({"measured", kMeasuredColor, t, Column(nominal->measured, j)});
      overlay.series.push_back({"nominal", kNominalColor, t, Column(nominal->simulated, j)});
      svg::LineChart residual;
      residual.title = "split '" + name + "': residual of " + channel;
      residual.x_label = "time [s]";
      residual.y_label = "measured - simulated";
      std::vector<double> before = Column(nominal->measured, j);
      const std::vector<double> sim = Column(nominal->simulated, j);
      for (std::size_t k = 0; k < before.size(); ++k) before[k] -= sim[k];
      residual.series.push_back({"nominal", kNominalColor, t, before});
      if (after_eval != nullptr && j < after_eval->simulated.cols()) {
        const std::vector<double> tf = ToVector(after_eval->time);
        overlay.series.push_back({"final", kFinalColor, tf, Column(after_eval->simulated, j)});
        std::vector<double> after = Column(after_eval->measured, j);
        const std::vector<double> fsim = Column(after_eval->simulated, j);
        for (std::size_t k = 0; k < after.size(); ++k) after[k] -= fsim[k];
        residual.series.push_back({"final", kFinalColor, tf, after});
        caption += ", final " + (ju < after_eval->simulation.channels.size()
                                     ? Format(after_eval->simulation.channels[ju].nrmse)
                                     : std::string("n/a"));
      }
      residual.references.push_back({0.0, "", "#444444", false});
      page->Figure("overlay:" + name + ":" + channel_name, svg::RenderLineChart(overlay),
                   caption + ".");
      page->Figure("residual:" + name + ":" + channel_name, svg::RenderLineChart(residual),
                   "Residual measured - simulated, split '" + name + "', " + channel + ".");
      charts += 2;
    }
  }
  if (charts == 0) page->Para("No validation split was evaluated: nothing to overlay.");
}

// 4. Round 1's screening chart, and each round's re-fit table and decision.
void Candidates(Page* page, const DiagnosisReport& d) {
  page->Heading("candidates", "Candidate effects");
  if (d.rounds.empty()) {
    page->Para("No selection round was run.");
    return;
  }
  const double alpha = d.options.significance;
  const Diagnosis& first = d.rounds.front().screening;
  if (first.screened.empty()) {
    page->Para("Round 1 found no candidate effect for this model.");
  } else {
    svg::BarChart c;
    c.title = "round 1: score-test statistic of each candidate";
    c.value_label = "LM statistic";
    c.series_labels = {"LM statistic"};
    c.colors = {kOutputColor};
    c.log_scale = true;
    c.mark_label = "chi-square critical value at p = " + Format(alpha, "%g") + " (row's dof)";
    c.mark_color = "#000000";
    for (const CandidateScore& s : first.screened) {
      c.rows.push_back({s.candidate.effect + " (" + s.candidate.detail + ")",
                        {s.score},
                        ChiSquareCritical(alpha, s.dof)});
    }
    page->Figure("screening:round 1", svg::RenderBarChart(c),
                 "Efficient score (LM) statistic at the neutral value, by candidate; a bar past "
                 "its mark rejects 'no effect' at p = " +
                     Format(alpha, "%g") + ".");
    Table t({"effect", "detail", "attachment", "LM", "dof", "p-value", "failure"});
    for (const CandidateScore& s : first.screened) {
      t.Row({Escape(s.candidate.effect), Escape(s.candidate.detail), Escape(s.candidate.attachment),
             Table::Num(Format(s.score, "%.4g")), Table::Num(std::to_string(s.dof)),
             Table::Num(Format(s.p_value, "%.3g")), Text(s.failure)});
    }
    page->body << t.Html();
  }
  for (const SelectionRound& r : d.rounds) {
    page->Sub("Round " + std::to_string(r.round) + " re-fits");
    const std::string decision =
        r.accepted ? "accepted the first re-fit"
                   : "not accepted" + (r.reason.empty() ? std::string() : ": " + r.reason);
    page->Para("Validation NRMSE before this round " +
               Format(r.screening.nominal_validation_nrmse) + "; " +
               std::to_string(r.screening.screened.size()) + " screened, " +
               std::to_string(r.screening.refits.size()) + " re-fitted; best re-fit: LR = " +
               Format(r.lr_statistic) + ", p = " + Format(r.lr_p_value, "%.3g") +
               ", relative gain " + Pct(r.relative_gain) + "; " + decision + ".");
    if (r.screening.refits.empty()) continue;
    Table t({"rank", "effect", "detail", "attachment", "LM", "NRMSE after", "relative gain", "AIC",
             "BIC", "status", "parameters (95 % interval)"});
    int rank = 0;
    for (const RefitResult& f : r.screening.refits) {
      const std::string status = !f.ok        ? "failed: " + f.failure
                                 : f.at_bound ? "ok, at a bound"
                                              : "ok";
      t.Row({Table::Num(std::to_string(++rank)), Escape(f.effect), Escape(f.detail),
             Escape(f.attachment), Table::Num(Format(f.score, "%.4g")),
             Table::Num(Format(f.validation_nrmse_after)), Table::Num(Pct(f.relative_gain)),
             Table::Num(Format(f.aic, "%.6g")), Table::Num(Format(f.bic, "%.6g")), Text(status),
             ParametersHtml(f.parameters)});
    }
    page->body << t.Html();
  }
}

// 5. The band shares of residual and measured output, per channel.
void SpectrumOf(Page* page, const Localization& loc, const std::string& which) {
  int charts = 0;
  for (const std::string& channel : ChannelNames(loc)) {
    svg::BarChart c;
    c.title = which + ": " + channel + ", share per frequency band";
    c.value_label = "share of the periodogram";
    c.series_labels = {"residual", "measured output"};
    c.colors = {which == "nominal" ? kNominalColor : kFinalColor, kOutputColor};
    c.percent = true;
    for (const BandEnergy& b : loc.bands) {
      if (b.channel != channel) continue;
      c.rows.push_back({Format(b.f_low, "%.3g") + " - " + Format(b.f_high, "%.3g") + " Hz (ratio " +
                            Format(b.power_ratio, "%.2g") + ")",
                        {b.residual_share, b.output_share},
                        kNaN});
    }
    if (c.rows.empty()) continue;
    page->Figure("spectrum:" + which + ":" + channel, svg::RenderBarChart(c),
                 "Share of the " + which +
                     " residual's and of the measured output's periodogram per band; ratio = "
                     "residual power / output power in the band.");
    ++charts;
  }
  if (charts == 0) page->Para("No frequency band was computed for the " + which + " residual.");
}

void Spectrum(Page* page, const DiagnosisReport& d) {
  page->Heading("spectrum", "Residual spectrum");
  SpectrumOf(page, d.nominal_localization, "nominal");
  if (d.accepted.empty()) {
    page->Para("No effect was accepted: the remainder is the nominal residual.");
  } else {
    SpectrumOf(page, d.remainder, "remainder");
  }
}

// 6. Residual autocorrelation and residual-input cross-correlation.
void Correlations(Page* page, const DiagnosisReport& d) {
  page->Heading("correlation", "Residual correlation");
  const Localization& nom = d.nominal_localization;
  const Localization* rem = d.accepted.empty() ? nullptr : &d.remainder;
  page->Para(
      "Autocorrelation r_ee(tau) of each channel's residual and cross-correlation r_eu(tau) "
      "with each input (positive tau: the residual follows the input), against the bound "
      "+-z / sqrt(N) of a white residual independent of the input at confidence " +
          Format(nom.options.confidence, "%g") + ".",
      "definition");
  auto bounds = [](svg::LineChart* c, double bound, const std::string& which) {
    c->references.push_back({bound, "+-bound (" + which + ") " + Format(bound, "%.3g")});
    c->references.push_back({-bound, ""});
  };
  int charts = 0;
  for (const Whiteness& w : nom.whiteness) {
    svg::LineChart c;
    c.title = "residual autocorrelation: " + w.channel;
    c.x_label = "lag [samples]";
    c.y_label = "r_ee";
    std::vector<double> lags;
    for (std::size_t i = 0; i < w.correlation.size(); ++i) lags.push_back(double(i + 1));
    c.series.push_back({"nominal", kNominalColor, lags, w.correlation, false, true});
    bounds(&c, w.bound, "nominal");
    std::string caption = "nominal: " + Pct(w.fraction_outside) +
                          " of the lags outside the bound, worst lag " +
                          std::to_string(w.worst_lag);
    if (rem != nullptr) {
      for (const Whiteness& r : rem->whiteness) {
        if (r.channel != w.channel) continue;
        std::vector<double> rl;
        for (std::size_t i = 0; i < r.correlation.size(); ++i) rl.push_back(double(i + 1));
        c.series.push_back({"remainder", kFinalColor, rl, r.correlation, false, true});
        if (std::fabs(r.bound - w.bound) > 1e-12) bounds(&c, r.bound, "remainder");
        caption += "; remainder: " + Pct(r.fraction_outside) + ", worst lag " +
                   std::to_string(r.worst_lag);
      }
    }
    page->Figure("autocorrelation:" + w.channel, svg::RenderLineChart(c), caption + ".");
    ++charts;
  }
  for (const CrossCorrelation& x : nom.cross_correlations) {
    svg::LineChart c;
    c.title = "residual-input cross-correlation: " + x.channel + " with " + x.input;
    c.x_label = "lag tau [samples]";
    c.y_label = "r_eu";
    std::vector<double> lags(x.lags.begin(), x.lags.end());
    c.series.push_back({"nominal", kNominalColor, lags, x.correlation, false, true});
    bounds(&c, x.bound, "nominal");
    std::string caption = "nominal: " + Pct(x.fraction_outside) + " of the lags outside, peak " +
                          Format(x.peak, "%.3g") + " at lag " + std::to_string(x.peak_lag);
    if (rem != nullptr) {
      for (const CrossCorrelation& r : rem->cross_correlations) {
        if (r.channel != x.channel || r.input != x.input) continue;
        std::vector<double> rl(r.lags.begin(), r.lags.end());
        c.series.push_back({"remainder", kFinalColor, rl, r.correlation, false, true});
        if (std::fabs(r.bound - x.bound) > 1e-12) bounds(&c, r.bound, "remainder");
        caption += "; remainder: " + Pct(r.fraction_outside) + ", peak " + Format(r.peak, "%.3g") +
                   " at lag " + std::to_string(r.peak_lag);
      }
    }
    page->Figure("crosscorrelation:" + x.channel + ":" + x.input, svg::RenderLineChart(c),
                 caption + ".");
    ++charts;
  }
  if (charts == 0) page->Para("No correlation was computed.");
}

// 7. The remainder, the stop reason, timings, options and run metadata.
void Remainder(Page* page, const DiagnosisReport& d,
               const std::vector<std::pair<std::string, std::string>>& run) {
  page->Heading("remainder", "What remains unexplained");
  page->Para(d.accepted.empty() ? "No effect was accepted: the remainder is the nominal gap."
                                : "The final model's residual, localised again:");
  const std::string brief = d.remainder.channels.empty() ? "" : d.remainder.BriefReport();
  if (!brief.empty()) page->Para(brief);
  EntriesTable(page, d.remainder.entries);
  std::vector<std::string> notes = d.nominal_localization.notes;
  for (const std::string& n : d.remainder.notes) {
    if (std::find(notes.begin(), notes.end(), n) == notes.end()) notes.push_back(n);
  }
  if (!notes.empty()) {
    page->body << "<ul class=\"note\">";
    for (const std::string& n : notes) page->body << "<li>" << Text(n) << "</li>";
    page->body << "</ul>\n";
  }
  page->Sub("Stop reason");
  page->Para(d.stop_reason.empty() ? "n/a" : d.stop_reason);
  page->Sub("Independent proposal: the learned force's sparse regression");
  page->Para(d.sparse_regression.BriefReport());
  for (const AxisRegression& a : d.sparse_regression.axes) {
    Table t({"axis", "effect", "shape", "coefficient", "share"});
    for (const SparseTerm& term : a.terms) {
      t.Row({Escape(a.velocity + " -> " + a.force), Escape(term.effect), Escape(term.shape),
             Table::Num(Format(term.coefficient)), Table::Num(Pct(term.share))});
    }
    page->Para(a.velocity + ": learned force RMS " + Format(a.learned_force_rms) + ", " +
               Pct(a.absorbed_by_nominal) + " of its energy along the nominal parameters; R^2 " +
               Format(a.r_squared) + " of the rest.");
    if (!t.empty()) page->body << t.Html();
  }
  if (!d.agreement.empty()) page->Para(d.agreement);
  page->Sub("Fits");
  page->Para("nominal: " + d.nominal.BriefReport());
  if (!d.accepted.empty()) page->Para("final: " + d.final_fit.BriefReport());
  page->Sub("Timings");
  if (d.seconds.empty()) {
    page->Para("No timing was recorded.");
  } else {
    Table t({"phase", "wall time [s]"});
    double total = 0.0;
    for (const auto& [phase, s] : d.seconds) {
      t.Row({Escape(phase), Table::Num(Format(s, "%.3f"))});
      total += s;
    }
    t.Row({"<b>total</b>", Table::Num(Format(total, "%.3f"))});
    page->body << t.Html();
  }
  page->Sub("Options");
  const DiagnoseOptions& o = d.options;
  const LocalizationOptions& lo = o.localization;
  Table opt({"option", "value"});
  auto row = [&opt](const std::string& k, const std::string& v) {
    opt.Row({Escape(k), Escape(v)});
  };
  row("max_effects", std::to_string(o.max_effects));
  row("significance", Format(o.significance, "%g"));
  row("min_relative_gain", Format(o.min_relative_gain, "%g"));
  row("refit_top", std::to_string(o.screening.refit_top));
  row("effects",
      o.screening.candidates.effects.empty() ? "all" : Join(o.screening.candidates.effects, ", "));
  row("localization", "num_windows " + std::to_string(lo.num_windows) + ", num_bins " +
                          std::to_string(lo.num_bins) + ", near_zero_fraction " +
                          Format(lo.near_zero_fraction, "%g") + ", reversal_samples " +
                          std::to_string(lo.reversal_samples) + ", max_lag " +
                          std::to_string(lo.max_lag) + ", num_bands " +
                          std::to_string(lo.num_bands) + ", confidence " +
                          Format(lo.confidence, "%g"));
  page->body << opt.Html();
  page->Sub("Run");
  if (run.empty()) {
    page->Para("No run metadata was given.");
  } else {
    Table t({"key", "value"});
    for (const auto& [k, v] : run) t.Row({Escape(k), Escape(v)});
    page->body << t.Html();
  }
}

}  // namespace

std::string DiagnosisHtml(const DiagnosisReport& report,
                          const std::vector<std::pair<std::string, std::string>>& run) {
  Page page;
  Summary(&page, report);
  Regimes(&page, report);
  Overlays(&page, report);
  Candidates(&page, report);
  Spectrum(&page, report);
  Correlations(&page, report);
  Remainder(&page, report, run);
  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
       << "<title>graybox diagnosis: " << Escape(report.problem) << "</title>\n"
       << "<style>" << kStyle << "</style>\n<script>" << kScript << "</script>\n</head>\n"
       << "<body data-figure-count=\"" << page.figures << "\">\n"
       << page.body.str() << "</body>\n</html>\n";
  return html.str();
}

}  // namespace graybox::diagnosis
