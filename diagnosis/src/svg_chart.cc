// Inline SVG charts for report.html: line charts (per-pixel min/max envelopes) and horizontal bar
// charts. Plain text, no plotting dependency.
#include "svg_chart.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <utility>

namespace graybox::diagnosis::svg {
namespace {

constexpr double kLeft = 80.0;      // line chart: y tick labels
constexpr double kRight = 20.0;     // line chart right margin
constexpr double kBarRight = 80.0;  // bar chart: room for the value after the longest bar
constexpr double kTitleY = 20.0;
constexpr double kLegendRow = 18.0;
constexpr double kBottom = 46.0;  // tick labels and the axis label
constexpr double kBarHeight = 12.0;
constexpr double kRowGap = 10.0;
constexpr double kCharWidth = 6.6;  // approximate width of one 12 px sans-serif character
const char* const kPalette[] = {"#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b"};

std::string Num(double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

std::string Color(const std::vector<std::string>& colors, std::size_t i) {
  if (i < colors.size() && !colors[i].empty()) return colors[i];
  return kPalette[i % (sizeof kPalette / sizeof kPalette[0])];
}

// Ticks at multiples of 1, 2 or 5 times a power of ten, about `count` of them over [lo, hi].
std::vector<double> NiceTicks(double lo, double hi, int count) {
  std::vector<double> ticks;
  const double span = hi - lo;
  if (!(span > 0.0) || !std::isfinite(span)) return {lo};
  const double raw = span / count;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double step = 10.0 * magnitude;
  for (double m : {1.0, 2.0, 5.0}) {
    if (m * magnitude >= raw) {
      step = m * magnitude;
      break;
    }
  }
  for (double t = std::ceil(lo / step) * step; t <= hi + 1e-9 * span; t += step) {
    ticks.push_back(std::fabs(t) < 1e-9 * step ? 0.0 : t);
  }
  return ticks;
}

std::string TickLabel(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// At most `max_chars` characters of `s` (UTF-8 aware), "..." replacing the tail when shortened.
std::string Shorten(const std::string& s, std::size_t max_chars) {
  std::vector<std::size_t> starts;  // byte offset of each character
  for (std::size_t i = 0; i < s.size(); ++i) {
    if ((static_cast<unsigned char>(s[i]) & 0xC0) != 0x80) starts.push_back(i);
  }
  if (starts.size() <= max_chars) return s;
  const std::size_t keep = max_chars > 3 ? max_chars - 3 : 0;
  return s.substr(0, starts[keep]) + "...";
}

// Pixel-column envelope of y over ascending x: for each column the first, min, max and last
// finite samples in order, so the drawn line covers every excursion. NaN splits the line.
std::vector<std::vector<std::pair<double, double>>> Envelope(const std::vector<double>& x,
                                                             const std::vector<double>& y,
                                                             double x0, double x1, int columns) {
  std::vector<std::vector<std::pair<double, double>>> lines(1);
  const std::size_t n = std::min(x.size(), y.size());
  const double span = x1 > x0 ? x1 - x0 : 1.0;
  auto column = [&](std::size_t k) {
    return static_cast<long>(std::floor((x[k] - x0) / span * columns));
  };
  std::size_t k = 0;
  while (k < n) {
    if (!std::isfinite(y[k]) || !std::isfinite(x[k])) {
      if (!lines.back().empty()) lines.emplace_back();
      ++k;
      continue;
    }
    const long col = column(k);
    std::size_t end = k, imin = k, imax = k;
    while (end < n && std::isfinite(y[end]) && std::isfinite(x[end]) && column(end) == col) {
      if (y[end] < y[imin]) imin = end;
      if (y[end] > y[imax]) imax = end;
      ++end;
    }
    std::vector<std::size_t> picks = {k, imin, imax, end - 1};
    std::sort(picks.begin(), picks.end());
    picks.erase(std::unique(picks.begin(), picks.end()), picks.end());
    for (std::size_t i : picks) lines.back().emplace_back(x[i], y[i]);
    k = end;
  }
  if (lines.back().empty()) lines.pop_back();
  return lines;
}

struct LegendItem {
  std::string label, color;
  bool dashed = false;
  bool tick = false;  // a short vertical mark instead of a line
};

// Legend items laid out left to right from x = left, wrapping at `right`; returns the rows used.
int Legend(std::ostringstream& svg, const std::vector<LegendItem>& items, double left, double right,
           double top) {
  if (items.empty()) return 0;
  double x = left;
  int rows = 1;
  for (const LegendItem& item : items) {
    const double w = 34.0 + kCharWidth * static_cast<double>(item.label.size()) + 14.0;
    if (x > left && x + w > right) {
      x = left;
      ++rows;
    }
    const double y = top + kLegendRow * (rows - 1) + 12.0;
    if (item.tick) {
      svg << "<line x1=\"" << Num(x + 12) << "\" x2=\"" << Num(x + 12) << "\" y1=\"" << Num(y - 10)
          << "\" y2=\"" << Num(y + 2) << "\" stroke=\"" << item.color << "\" stroke-width=\"2\"/>";
    } else {
      svg << "<line x1=\"" << Num(x) << "\" x2=\"" << Num(x + 24) << "\" y1=\"" << Num(y - 4)
          << "\" y2=\"" << Num(y - 4) << "\" stroke=\"" << item.color << "\" stroke-width=\""
          << (item.dashed ? "1.5\" stroke-dasharray=\"5 3" : "3") << "\"/>";
    }
    svg << "<text x=\"" << Num(x + 30) << "\" y=\"" << Num(y) << "\">" << Escape(item.label)
        << "</text>\n";
    x += w;
  }
  return rows;
}

std::string Open(double width, double height, const std::string& title) {
  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << Num(width) << "\" height=\""
      << Num(height) << "\" viewBox=\"0 0 " << Num(width) << " " << Num(height)
      << "\" font-family=\"sans-serif\" font-size=\"12\" role=\"img\">"
      << "<title>" << Escape(title) << "</title>\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text x=\"" << Num(width / 2) << "\" y=\"" << Num(kTitleY)
      << "\" text-anchor=\"middle\" font-size=\"14\">" << Escape(title) << "</text>\n";
  return svg.str();
}

// Rows the legend will take (the same layout as Legend, without drawing).
int LegendRows(const std::vector<LegendItem>& items, double left, double right) {
  std::ostringstream discard;
  return Legend(discard, items, left, right, 0.0);
}

}  // namespace

std::string Escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
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
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string Format(double v, const char* format) {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string RenderLineChart(const LineChart& chart) {
  const double width = chart.width;
  const double plot_w = width - kLeft - kRight;
  std::vector<LegendItem> legend;
  for (std::size_t i = 0; i < chart.series.size(); ++i) {
    const Series& s = chart.series[i];
    legend.push_back({s.label, s.color.empty() ? Color({}, i) : s.color, s.dashed, false});
  }
  for (const ReferenceLine& r : chart.references) {
    if (!r.label.empty()) legend.push_back({r.label, r.color, r.dashed, false});
  }
  const int legend_rows = LegendRows(legend, kLeft, width - kRight);
  const double top = kTitleY + 12.0 + kLegendRow * legend_rows + 6.0;
  const double height = top + chart.plot_height + kBottom;

  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0;
  double lo = x0, hi = -x0;
  for (const Series& s : chart.series) {
    const std::size_t n = std::min(s.x.size(), s.y.size());
    for (std::size_t k = 0; k < n; ++k) {
      if (!std::isfinite(s.x[k]) || !std::isfinite(s.y[k])) continue;
      x0 = std::min(x0, s.x[k]);
      x1 = std::max(x1, s.x[k]);
      lo = std::min(lo, s.y[k]);
      hi = std::max(hi, s.y[k]);
    }
  }
  const bool empty = !std::isfinite(x0);
  for (const ReferenceLine& r : chart.references) {
    if (std::isfinite(r.y)) lo = std::min(lo, r.y), hi = std::max(hi, r.y);
  }
  if (empty) x0 = 0.0, x1 = 1.0;
  if (!(x1 > x0)) x0 -= 0.5, x1 += 0.5;
  if (!std::isfinite(lo)) lo = -1.0, hi = 1.0;
  if (hi - lo < 1e-300 + 1e-12 * std::fabs(hi)) {
    lo -= 0.5 + 0.01 * std::fabs(lo);
    hi += 0.5 + 0.01 * std::fabs(hi);
  }
  const double pad = 0.05 * (hi - lo);
  lo -= pad;
  hi += pad;
  auto px = [&](double v) { return kLeft + (v - x0) / (x1 - x0) * plot_w; };
  auto py = [&](double v) { return top + (hi - v) / (hi - lo) * chart.plot_height; };

  std::ostringstream svg;
  svg << Open(width, height, chart.title);
  Legend(svg, legend, kLeft, width - kRight, kTitleY + 10.0);
  const double bottom = top + chart.plot_height;
  for (double v : NiceTicks(lo, hi, 5)) {
    svg << "<line x1=\"" << Num(kLeft) << "\" x2=\"" << Num(kLeft + plot_w) << "\" y1=\""
        << Num(py(v)) << "\" y2=\"" << Num(py(v)) << "\" stroke=\"#e4e4e4\"/>"
        << "<text x=\"" << Num(kLeft - 6) << "\" y=\"" << Num(py(v) + 4)
        << "\" text-anchor=\"end\">" << TickLabel(v) << "</text>\n";
  }
  for (double v : NiceTicks(x0, x1, 8)) {
    svg << "<line x1=\"" << Num(px(v)) << "\" x2=\"" << Num(px(v)) << "\" y1=\"" << Num(top)
        << "\" y2=\"" << Num(bottom) << "\" stroke=\"#eeeeee\"/>"
        << "<text x=\"" << Num(px(v)) << "\" y=\"" << Num(bottom + 15)
        << "\" text-anchor=\"middle\">" << TickLabel(v) << "</text>\n";
  }
  svg << "<rect x=\"" << Num(kLeft) << "\" y=\"" << Num(top) << "\" width=\"" << Num(plot_w)
      << "\" height=\"" << Num(chart.plot_height) << "\" fill=\"none\" stroke=\"#444\"/>\n";
  svg << "<text x=\"" << Num(kLeft + plot_w / 2) << "\" y=\"" << Num(bottom + 32)
      << "\" text-anchor=\"middle\">" << Escape(chart.x_label) << "</text>\n";
  svg << "<text transform=\"translate(14," << Num(top + chart.plot_height / 2)
      << ") rotate(-90)\" text-anchor=\"middle\">" << Escape(chart.y_label) << "</text>\n";
  for (const ReferenceLine& r : chart.references) {
    if (!std::isfinite(r.y)) continue;
    svg << "<line x1=\"" << Num(kLeft) << "\" x2=\"" << Num(kLeft + plot_w) << "\" y1=\""
        << Num(py(r.y)) << "\" y2=\"" << Num(py(r.y)) << "\" stroke=\"" << r.color << "\""
        << (r.dashed ? " stroke-dasharray=\"5 3\"" : "") << "/>\n";
  }
  for (std::size_t i = 0; i < chart.series.size(); ++i) {
    const Series& s = chart.series[i];
    const std::string color = s.color.empty() ? Color({}, i) : s.color;
    for (const auto& line : Envelope(s.x, s.y, x0, x1, static_cast<int>(std::lround(plot_w)))) {
      svg << "<polyline fill=\"none\" stroke=\"" << color << "\" stroke-width=\"1.2\""
          << (s.dashed ? " stroke-dasharray=\"5 3\"" : "") << " points=\"";
      for (const auto& [xv, yv] : line) svg << Num(px(xv)) << "," << Num(py(yv)) << " ";
      svg << "\"/>\n";
      if (s.markers) {
        for (const auto& [xv, yv] : line) {
          svg << "<circle cx=\"" << Num(px(xv)) << "\" cy=\"" << Num(py(yv)) << "\" r=\"2\" fill=\""
              << color << "\"/>";
        }
        svg << "\n";
      }
    }
  }
  if (empty) {
    svg << "<text x=\"" << Num(kLeft + plot_w / 2) << "\" y=\"" << Num(top + chart.plot_height / 2)
        << "\" text-anchor=\"middle\" fill=\"#888\">no finite value</text>\n";
  }
  svg << "</svg>";
  return svg.str();
}

std::string RenderBarChart(const BarChart& chart) {
  const double width = chart.width;
  const double left = chart.label_width;
  const double plot_w = width - left - kBarRight;
  const std::size_t num_series = chart.series_labels.size();
  std::vector<LegendItem> legend;
  for (std::size_t i = 0; i < num_series; ++i) {
    legend.push_back({chart.series_labels[i], Color(chart.colors, i), false, false});
  }
  if (!chart.mark_label.empty())
    legend.push_back({chart.mark_label, chart.mark_color, false, true});
  const int legend_rows = LegendRows(legend, 10.0, width - 10.0);
  const double top = kTitleY + 12.0 + kLegendRow * legend_rows + 8.0;
  const double row_h = std::max<double>(1, num_series) * kBarHeight + kRowGap;
  const double plot_h = std::max<double>(1, chart.rows.size()) * row_h;
  const double height = top + plot_h + kBottom;

  // The value axis.
  double vmin = std::numeric_limits<double>::infinity(), vmax = -vmin;
  double pos_min = vmin, pos_max = 0.0;
  auto include = [&](double v) {
    if (!std::isfinite(v)) return;
    vmin = std::min(vmin, v);
    vmax = std::max(vmax, v);
    if (v > 0.0) pos_min = std::min(pos_min, v), pos_max = std::max(pos_max, v);
  };
  for (const BarRow& r : chart.rows) {
    for (double v : r.values) include(v);
    if (!chart.mark_label.empty()) include(r.mark);
  }
  double lo = 0.0, hi = 1.0;
  std::vector<double> ticks;
  if (chart.log_scale) {
    double d0 = 0.0, d1 = 1.0;
    if (pos_max > 0.0) {
      d0 = std::floor(std::log10(pos_min));
      d1 = std::ceil(std::log10(pos_max));
      if (d1 <= d0) d1 = d0 + 1.0;
    }
    lo = d0;
    hi = d1;
    const double step = std::ceil((d1 - d0) / 8.0);
    for (double d = d0; d <= d1 + 1e-9; d += step) ticks.push_back(d);
  } else {
    if (std::isfinite(vmin)) {
      lo = std::min(0.0, vmin);
      hi = std::max(0.0, vmax);
    }
    if (!(hi > lo)) hi = lo + 1.0;
    ticks = NiceTicks(lo, hi, 6);
  }
  auto px = [&](double v) {
    double a = v;
    if (chart.log_scale) a = v > 0.0 ? std::log10(v) : lo;
    a = std::clamp(a, lo, hi);
    return left + (a - lo) / (hi - lo) * plot_w;
  };
  auto value_text = [&](double v) {
    if (!std::isfinite(v)) return std::string("n/a");
    return chart.percent ? Format(100.0 * v, "%.3g") + " %" : Format(v, "%.3g");
  };

  std::ostringstream svg;
  svg << Open(width, height, chart.title);
  Legend(svg, legend, 10.0, width - 10.0, kTitleY + 10.0);
  const double bottom = top + plot_h;
  for (double t : ticks) {
    const double x = left + (t - lo) / (hi - lo) * plot_w;
    std::string label;
    if (chart.log_scale) {
      label = Format(std::pow(10.0, t), "%g");
    } else {
      label = chart.percent ? TickLabel(100.0 * t) + " %" : TickLabel(t);
    }
    svg << "<line x1=\"" << Num(x) << "\" x2=\"" << Num(x) << "\" y1=\"" << Num(top) << "\" y2=\""
        << Num(bottom) << "\" stroke=\"#e4e4e4\"/>"
        << "<text x=\"" << Num(x) << "\" y=\"" << Num(bottom + 15) << "\" text-anchor=\"middle\">"
        << label << "</text>\n";
  }
  svg << "<text x=\"" << Num(left + plot_w / 2) << "\" y=\"" << Num(bottom + 32)
      << "\" text-anchor=\"middle\">" << Escape(chart.value_label)
      << (chart.log_scale ? " (log scale)" : "") << "</text>\n";
  const std::size_t max_chars = static_cast<std::size_t>(std::max(8.0, (left - 12.0) / kCharWidth));
  const double base = px(chart.log_scale ? std::pow(10.0, lo) : 0.0);
  for (std::size_t r = 0; r < chart.rows.size(); ++r) {
    const BarRow& row = chart.rows[r];
    const double y0 = top + r * row_h + kRowGap / 2;
    svg << "<g><text x=\"" << Num(left - 6) << "\" y=\"" << Num(y0 + row_h / 2 - kRowGap / 2 + 4)
        << "\" text-anchor=\"end\">";
    const std::string shown = Shorten(row.label, max_chars);
    if (shown != row.label) svg << "<title>" << Escape(row.label) << "</title>";  // tooltip
    svg << Escape(shown) << "</text>";
    for (std::size_t s = 0; s < num_series; ++s) {
      const double v =
          s < row.values.size() ? row.values[s] : std::numeric_limits<double>::quiet_NaN();
      const double y = y0 + s * kBarHeight;
      double x_a = base, x_b = base;
      if (std::isfinite(v)) {
        const double xv = px(v);
        x_a = std::min(base, xv);
        x_b = std::max(base, xv);
      }
      svg << "<rect x=\"" << Num(x_a) << "\" y=\"" << Num(y + 1) << "\" width=\""
          << Num(std::max(0.0, x_b - x_a)) << "\" height=\"" << Num(kBarHeight - 2) << "\" fill=\""
          << Color(chart.colors, s) << "\"/>"
          << "<text x=\"" << Num(x_b + 4) << "\" y=\"" << Num(y + kBarHeight - 2)
          << "\" font-size=\"10\">" << value_text(v) << "</text>";
    }
    if (!chart.mark_label.empty() && std::isfinite(row.mark)) {
      const double x = px(row.mark);
      svg << "<line x1=\"" << Num(x) << "\" x2=\"" << Num(x) << "\" y1=\"" << Num(y0 - 3)
          << "\" y2=\"" << Num(y0 + num_series * kBarHeight + 3) << "\" stroke=\""
          << chart.mark_color << "\" stroke-width=\"2\"/>";
    }
    svg << "</g>\n";
  }
  svg << "<line x1=\"" << Num(base) << "\" x2=\"" << Num(base) << "\" y1=\"" << Num(top)
      << "\" y2=\"" << Num(bottom) << "\" stroke=\"#444\"/>\n";
  if (chart.rows.empty()) {
    svg << "<text x=\"" << Num(left + plot_w / 2) << "\" y=\"" << Num(top + row_h / 2)
        << "\" text-anchor=\"middle\" fill=\"#888\">no rows</text>\n";
  }
  svg << "</svg>";
  return svg.str();
}

}  // namespace graybox::diagnosis::svg
