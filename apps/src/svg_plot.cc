// Plain-text SVG plots (no plotting dependency): stacked panels sharing the time axis, with
// "nice" ticks, a legend, and polylines reduced to a min/max envelope per pixel column so a
// 25000-sample record stays a small file that looks the same.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "app.h"

namespace graybox::app {
namespace {

constexpr double kWidth = 960.0;
constexpr double kPanelHeight = 230.0;
constexpr double kLeft = 90.0;
constexpr double kRight = 20.0;
constexpr double kTitleHeight = 56.0;  // figure title at y = 22, first panel title at 50
constexpr double kPanelGap = 46.0;
constexpr double kBottom = 44.0;

struct Series {
  std::string label;
  std::string color;
  Eigen::VectorXd y;
  bool dashed = false;
};

struct Panel {
  std::string title;
  std::vector<Series> series;
};

std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string Num(double v, const char* format = "%.1f") {
  char buf[48];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// Ticks at multiples of 1, 2 or 5 times a power of ten, about `count` of them over [lo, hi].
std::vector<double> NiceTicks(double lo, double hi, int count) {
  std::vector<double> ticks;
  const double span = hi - lo;
  if (!(span > 0.0) || !std::isfinite(span)) return {lo};
  const double raw = span / count;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double step = magnitude;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * magnitude >= raw) {
      step = m * magnitude;
      break;
    }
  }
  for (double t = std::ceil(lo / step) * step; t <= hi + 1e-9 * span; t += step) {
    ticks.push_back(std::fabs(t) < 1e-12 * span ? 0.0 : t);
  }
  return ticks;
}

std::string TickLabel(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// Pixel-column envelope: for each column the first, min, max and last finite samples in order,
// so the drawn line covers every excursion. NaN splits the line.
std::vector<std::vector<std::pair<double, double>>> Envelope(const Eigen::VectorXd& t,
                                                             const Eigen::VectorXd& y, double t0,
                                                             double t1, int columns) {
  std::vector<std::vector<std::pair<double, double>>> lines(1);
  const Eigen::Index n = std::min(t.size(), y.size());
  const double span = t1 > t0 ? t1 - t0 : 1.0;
  Eigen::Index k = 0;
  while (k < n) {
    if (!std::isfinite(y[k])) {
      if (!lines.back().empty()) lines.emplace_back();
      ++k;
      continue;
    }
    const int col = static_cast<int>(std::floor((t[k] - t0) / span * columns));
    Eigen::Index end = k;
    Eigen::Index imin = k, imax = k;
    while (end < n && std::isfinite(y[end]) &&
           static_cast<int>(std::floor((t[end] - t0) / span * columns)) == col) {
      if (y[end] < y[imin]) imin = end;
      if (y[end] > y[imax]) imax = end;
      ++end;
    }
    std::vector<Eigen::Index> picks = {k, imin, imax, end - 1};
    std::sort(picks.begin(), picks.end());
    picks.erase(std::unique(picks.begin(), picks.end()), picks.end());
    for (Eigen::Index i : picks) lines.back().emplace_back(t[i], y[i]);
    k = end;
  }
  if (lines.back().empty()) lines.pop_back();
  return lines;
}

std::string Figure(const std::string& title, const Eigen::VectorXd& t,
                   const std::vector<Panel>& panels) {
  const double plot_w = kWidth - kLeft - kRight;
  const double height =
      kTitleHeight + panels.size() * (kPanelHeight + kPanelGap) + kBottom - kPanelGap;
  std::ostringstream svg;
  svg << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << Num(kWidth, "%.0f")
      << "\" height=\"" << Num(height, "%.0f") << "\" viewBox=\"0 0 " << Num(kWidth, "%.0f") << " "
      << Num(height, "%.0f") << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text x=\"" << Num(kWidth / 2) << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">"
      << Escape(title) << "</text>\n";
  const double t0 = t.size() ? t[0] : 0.0;
  const double t1 = t.size() ? t[t.size() - 1] : 1.0;
  const double tspan = t1 > t0 ? t1 - t0 : 1.0;
  for (std::size_t p = 0; p < panels.size(); ++p) {
    const Panel& panel = panels[p];
    const double top = kTitleHeight + p * (kPanelHeight + kPanelGap);
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Series& s : panel.series) {
      for (Eigen::Index k = 0; k < s.y.size(); ++k) {
        if (std::isfinite(s.y[k])) {
          lo = std::min(lo, s.y[k]);
          hi = std::max(hi, s.y[k]);
        }
      }
    }
    if (!std::isfinite(lo)) lo = -1.0, hi = 1.0;
    if (hi - lo < 1e-300 + 1e-12 * std::fabs(hi))
      lo -= 0.5 + std::fabs(lo) * 0.01, hi += 0.5 + std::fabs(hi) * 0.01;
    const double pad = 0.05 * (hi - lo);
    lo -= pad;
    hi += pad;
    auto px = [&](double tv) { return kLeft + (tv - t0) / tspan * plot_w; };
    auto py = [&](double v) { return top + (hi - v) / (hi - lo) * kPanelHeight; };
    svg << "<g>\n<text x=\"" << Num(kLeft) << "\" y=\"" << Num(top - 6) << "\" font-size=\"13\">"
        << Escape(panel.title) << "</text>\n";
    svg << "<rect x=\"" << Num(kLeft) << "\" y=\"" << Num(top) << "\" width=\"" << Num(plot_w)
        << "\" height=\"" << Num(kPanelHeight) << "\" fill=\"none\" stroke=\"#444\"/>\n";
    for (double v : NiceTicks(lo, hi, 5)) {
      svg << "<line x1=\"" << Num(kLeft) << "\" x2=\"" << Num(kLeft + plot_w) << "\" y1=\""
          << Num(py(v)) << "\" y2=\"" << Num(py(v)) << "\" stroke=\"#e4e4e4\"/>\n"
          << "<text x=\"" << Num(kLeft - 6) << "\" y=\"" << Num(py(v) + 4)
          << "\" text-anchor=\"end\">" << TickLabel(v) << "</text>\n";
    }
    for (double v : NiceTicks(t0, t1, 8)) {
      svg << "<line x1=\"" << Num(px(v)) << "\" x2=\"" << Num(px(v)) << "\" y1=\"" << Num(top)
          << "\" y2=\"" << Num(top + kPanelHeight) << "\" stroke=\"#eeeeee\"/>\n"
          << "<text x=\"" << Num(px(v)) << "\" y=\"" << Num(top + kPanelHeight + 15)
          << "\" text-anchor=\"middle\">" << TickLabel(v) << "</text>\n";
    }
    svg << "<text x=\"" << Num(kLeft + plot_w / 2) << "\" y=\"" << Num(top + kPanelHeight + 31)
        << "\" text-anchor=\"middle\">time [s]</text>\n";
    for (std::size_t s = 0; s < panel.series.size(); ++s) {
      const Series& series = panel.series[s];
      for (const auto& line :
           Envelope(t, series.y, t0, t1, static_cast<int>(std::lround(plot_w)))) {
        svg << "<polyline fill=\"none\" stroke=\"" << series.color << "\" stroke-width=\"1\""
            << (series.dashed ? " stroke-dasharray=\"4 3\"" : "") << " points=\"";
        for (const auto& [tv, v] : line) svg << Num(px(tv)) << "," << Num(py(v)) << " ";
        svg << "\"/>\n";
      }
      const double lx = kLeft + plot_w - 200.0, ly = top + 16.0 + 16.0 * s;
      svg << "<line x1=\"" << Num(lx) << "\" x2=\"" << Num(lx + 24) << "\" y1=\"" << Num(ly - 4)
          << "\" y2=\"" << Num(ly - 4) << "\" stroke=\"" << series.color
          << "\" stroke-width=\"2\"/>\n<text x=\"" << Num(lx + 30) << "\" y=\"" << Num(ly) << "\">"
          << Escape(series.label) << "</text>\n";
    }
    svg << "</g>\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

std::string Label(const std::string& name, const std::string& unit) {
  return unit.empty() ? name : name + " [" + unit + "]";
}

std::string Fit(const estimators::MetricReport& report, std::size_t j) {
  if (j >= report.channels.size()) return "";
  char buf[96];
  std::snprintf(buf, sizeof buf, " (FIT %.2f %%, RMSE %.4g)", report.channels[j].fit_percent,
                report.channels[j].rmse);
  return buf;
}

}  // namespace

std::string PlotOutputs(const estimators::SplitEvaluation& e,
                        const models::StateSpaceModel& model) {
  std::vector<Panel> panels;
  for (int j = 0; j < model.NumOutputs(); ++j) {
    Panel p;
    p.title = Label(model.outputs[j].name, model.outputs[j].unit) + Fit(e.simulation, j);
    p.series.push_back({"measured", "#222222", e.measured.col(j), false});
    p.series.push_back({"simulated", "#d62728", e.simulated.col(j), false});
    panels.push_back(std::move(p));
  }
  return Figure("split '" + e.name + "' (" + estimators::SplitRoleName(e.role) +
                    "): measured and simulated outputs",
                e.time, panels);
}

std::string PlotResiduals(const estimators::SplitEvaluation& e,
                          const models::StateSpaceModel& model) {
  std::vector<Panel> panels;
  for (int j = 0; j < model.NumOutputs(); ++j) {
    Panel p;
    p.title = "residual " + Label(model.outputs[j].name, model.outputs[j].unit) +
              " = measured - simulated";
    p.series.push_back({"residual", "#1f77b4", e.measured.col(j) - e.simulated.col(j), false});
    panels.push_back(std::move(p));
  }
  return Figure(
      "split '" + e.name + "' (" + estimators::SplitRoleName(e.role) + "): simulation residuals",
      e.time, panels);
}

std::string PlotEquation(const estimators::SplitEvaluation& e) {
  std::vector<Panel> panels;
  for (std::size_t j = 0; j < e.equation_channels.size(); ++j) {
    const int c = static_cast<int>(j);
    Panel p;
    p.title = Label(e.equation_channels[j], e.equation_units[j]) + Fit(e.equation, j);
    p.series.push_back({"measured", "#222222", e.equation_measured.col(c), false});
    p.series.push_back({"model", "#2ca02c", e.equation_predicted.col(c), false});
    panels.push_back(std::move(p));
    Panel r;
    r.title =
        "residual " + Label(e.equation_channels[j], e.equation_units[j]) + " = measured - model";
    r.series.push_back(
        {"residual", "#1f77b4", e.equation_measured.col(c) - e.equation_predicted.col(c), false});
    panels.push_back(std::move(r));
  }
  return Figure("split '" + e.name + "' (" + estimators::SplitRoleName(e.role) +
                    "): equation error after preprocessing",
                e.equation_time, panels);
}

}  // namespace graybox::app
