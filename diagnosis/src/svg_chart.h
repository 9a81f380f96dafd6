// Inline SVG charts for report.html (private to the diagnosis library): line charts with "nice"
// ticks whose long records are reduced to a min/max envelope per pixel column (a 25000-sample
// record stays small and looks the same), and horizontal bar charts with grouped bars, a linear
// or logarithmic value axis and per-row reference marks.
//
//   LineChart c;
//   c.title = "split 'test': force";
//   c.series.push_back({"measured", "#222222", time, y});
//   std::string svg = RenderLineChart(c);   // "<svg ...><title>...</title>...</svg>"
//
// Every text is escaped; NaN values are gaps in a line and "n/a" next to a bar. The <svg> has a
// width, a height and a viewBox, its first child is a <title> (the chart's title).
#pragma once

#include <string>
#include <vector>

namespace graybox::diagnosis::svg {

/// `s` with &, <, >, " and ' replaced by entities (HTML text and attribute values).
std::string Escape(const std::string& s);

/// `v` with printf format `format` ("%.4g"), or "n/a" when it is NaN or infinite.
std::string Format(double v, const char* format = "%.4g");

/// One line of a line chart: y over x (x ascending; NaN in y breaks the line).
struct Series {
  std::string label;
  std::string color;
  std::vector<double> x, y;
  bool dashed = false;
  /// Draw a dot on every point (short series such as correlations over lags).
  bool markers = false;
};

/// A horizontal reference line across the plot (a confidence bound, zero).
struct ReferenceLine {
  double y = 0.0;
  std::string label;  // in the legend; empty: not listed
  std::string color = "#7f7f7f";
  bool dashed = true;
};

struct LineChart {
  std::string title;
  std::string x_label, y_label;
  std::vector<Series> series;
  std::vector<ReferenceLine> references;
  double width = 900.0, plot_height = 220.0;
};

/// The chart as one <svg> element. An empty chart (no finite point) draws its axes and a note.
std::string RenderLineChart(const LineChart& chart);

/// One row of a bar chart: one bar per series, and optional marks drawn across the row.
struct BarRow {
  std::string label;
  std::vector<double> values;  // one per BarChart::series_labels (NaN: "n/a")
  double mark = 0.0;           // drawn when BarChart::mark_label is set (NaN: none)
};

struct BarChart {
  std::string title;
  std::string value_label;  // the value axis
  std::vector<std::string> series_labels, colors;
  std::vector<BarRow> rows;
  /// Logarithmic value axis (decades); values <= 0 are drawn at the axis' start.
  bool log_scale = false;
  /// Value format of the number printed after each bar ("%.3g"); percent: value * 100 and " %".
  bool percent = false;
  /// When non-empty, BarRow::mark is drawn as a vertical tick across each row, listed in the
  /// legend with this label.
  std::string mark_label;
  std::string mark_color = "#000000";
  double width = 900.0;
  /// The row labels' column; a longer label is shortened with "..." (its full text in a tooltip).
  double label_width = 340.0;
};

/// The chart as one <svg> element.
std::string RenderBarChart(const BarChart& chart);

}  // namespace graybox::diagnosis::svg
