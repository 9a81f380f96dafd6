// Reading numeric CSV files: one header row of column names (or names given by the caller), then
// one sample per line.
//
//   CsvOptions options;
//   options.columns = {"/joint_states/effort[6]_y", "/joint_states/position[3]_y"};
//   options.empty_cells = CsvEmptyCells::kDropTrailingRows;
//   CsvTable t = ReadCsv("simwithinitpres1multisine.csv", options);
//   Eigen::VectorXd theta = t.Column("/joint_states/position[3]_y");
//
//   CsvOptions no_header;              // DC motor files have no header row
//   no_header.has_header = false;
//   no_header.column_names = {"time", "pwm", "speed"};
//
// Format: fields separated by `delimiter`; a field may be enclosed in double quotes (a doubled
// quote inside stands for one quote); spaces around a field are ignored; CR LF and LF line ends
// are both accepted; blank lines are skipped. A row may carry one extra, empty field after the
// last column (a trailing delimiter, as in rqt_plot exports). Numbers are parsed with std::strtod
// (so "1e-3", "nan", "inf" are accepted; use Experiment::Validate to reject non-finite samples)
// and must use the whole field; the decimal point is '.' unless the program changed the C locale.
//
// Only the selected columns are parsed, so text or empty cells in other columns do no harm.
//
// Errors (std::invalid_argument naming the file, the 1-based line number and, for cells, the
// 1-based column number and column name):
//   "csv_file: 'x.csv' line 12, column 3 ('speed'): expected a number, got '12,5.3'"
//   "csv_file: 'x.csv' line 7: expected 3 fields, got 2"
//   "csv_file: 'x.csv': no column 'sped'; did you mean 'speed'? (columns: time, pwm, speed)"
// A missing file gives "csv_file: 'x.csv': file not found".
#pragma once

#include <cstddef>
#include <cstdint>

#include <string>
#include <vector>

#include <Eigen/Core>

namespace graybox::estimators {

/// What to do with an empty (or all-blank) cell in a selected column.
enum class CsvEmptyCells {
  kError,             // std::invalid_argument naming line and column (default)
  kNaN,               // store NaN
  kDropTrailingRows,  // drop the rows at the end of the file that have an empty selected cell
                      // (ROS exports where topics stop at different times); an empty cell
                      // followed by a complete row is still an error
};

/// Limits that keep a hostile file from exhausting memory: ReadCsv refuses a file above
/// kMaxCsvBytes (and anything that is not a regular file, such as /dev/zero), ParseCsv a line
/// above kMaxCsvLineBytes characters or kMaxCsvFields fields, each naming the file (and line).
inline constexpr std::uintmax_t kMaxCsvBytes = std::uintmax_t{1} << 30;  // 1 GiB
inline constexpr std::size_t kMaxCsvLineBytes = std::size_t{1} << 20;    // 1 MiB
inline constexpr int kMaxCsvFields = 10000;

struct CsvOptions {
  char delimiter = ',';
  /// First non-blank line holds the column names.
  bool has_header = true;
  /// Column names when has_header is false (one per field), or to rename the header's columns
  /// (then the count must match the header). Empty: use the header; without header the columns
  /// are called "c0", "c1", ...
  std::vector<std::string> column_names;
  /// Columns to read, by name, in the order wanted; empty reads all columns.
  std::vector<std::string> columns;
  CsvEmptyCells empty_cells = CsvEmptyCells::kError;
};

/// Parsed columns: data(k, j) is sample k of column names[j].
struct CsvTable {
  std::vector<std::string> names;
  Eigen::MatrixXd data;
  /// 1-based line number in the file of each data row (for messages of later checks).
  std::vector<int> lines;

  int NumRows() const { return static_cast<int>(data.rows()); }
  int NumColumns() const { return static_cast<int>(data.cols()); }
  /// Index of a column; std::invalid_argument with a did-you-mean when absent.
  int ColumnIndex(const std::string& name) const;
  Eigen::VectorXd Column(const std::string& name) const;
  /// Several columns as an N x k matrix, in the given order.
  Eigen::MatrixXd Columns(const std::vector<std::string>& selection) const;
};

/// Reads a CSV file; see the file comment for the format and the errors.
CsvTable ReadCsv(const std::string& path, const CsvOptions& options = {});

/// Parses CSV text held in memory (`source` names it in error messages).
CsvTable ParseCsv(const std::string& text, const CsvOptions& options = {},
                  const std::string& source = "<text>");

}  // namespace graybox::estimators
