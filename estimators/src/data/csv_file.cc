#include "graybox/estimators/data/csv_file.h"
#include "graybox/util/did_you_mean.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "graybox/models/block.h"
#include "graybox/util/read_file.h"

namespace graybox::estimators {
namespace {

std::string Trim(const std::string& s) {
  size_t b = 0;
  size_t e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t')) --e;
  return s.substr(b, e - b);
}

// Splits one line into fields, honouring double quotes. Unquoted fields are trimmed.
std::vector<std::string> SplitFields(const std::string& line, char delimiter) {
  std::vector<std::string> fields;
  std::string field;
  bool quoted = false;
  bool was_quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"') {
        if (i + 1 < line.size() && line[i + 1] == '"') {
          field += '"';
          ++i;
        } else {
          quoted = false;
        }
      } else {
        field += c;
      }
    } else if (c == '"' && Trim(field).empty()) {
      quoted = true;
      was_quoted = true;
      field.clear();
    } else if (c == delimiter) {
      fields.push_back(was_quoted ? field : Trim(field));
      field.clear();
      was_quoted = false;
    } else if (!(was_quoted && (c == ' ' || c == '\t'))) {
      field += c;
    }
  }
  fields.push_back(was_quoted ? field : Trim(field));
  return fields;
}

bool IsBlank(const std::string& s) { return s.find_first_not_of(" \t\r") == std::string::npos; }

std::string JoinNames(const std::vector<std::string>& names) {
  std::string out;
  for (size_t i = 0; i < names.size(); ++i) out += (i > 0 ? ", " : "") + names[i];
  return out;
}

}  // namespace

int CsvTable::ColumnIndex(const std::string& name) const {
  for (size_t j = 0; j < names.size(); ++j) {
    if (names[j] == name) return static_cast<int>(j);
  }
  std::string message = "csv_file: no column '" + name + "'";
  const std::string hint = util::DidYouMean(name, names);
  if (!hint.empty()) message += "; did you mean '" + hint + "'?";
  throw std::invalid_argument(message + " (columns: " + JoinNames(names) + ")");
}

Eigen::VectorXd CsvTable::Column(const std::string& name) const {
  return data.col(ColumnIndex(name));
}

Eigen::MatrixXd CsvTable::Columns(const std::vector<std::string>& selection) const {
  Eigen::MatrixXd out(data.rows(), static_cast<Eigen::Index>(selection.size()));
  for (size_t j = 0; j < selection.size(); ++j) {
    out.col(static_cast<Eigen::Index>(j)) = data.col(ColumnIndex(selection[j]));
  }
  return out;
}

CsvTable ParseCsv(const std::string& text, const CsvOptions& options, const std::string& source) {
  const std::string where = "csv_file: '" + source + "'";
  if (options.delimiter == '"' || options.delimiter == '\n' || options.delimiter == '\r') {
    throw std::invalid_argument(where +
                                ": expected a delimiter other than quote or line end, got " + "'" +
                                std::string(1, options.delimiter) + "'");
  }
  std::istringstream in(text);
  std::string line;
  int line_number = 0;

  // Column names.
  std::vector<std::string> names;
  int header_fields = -1;
  if (options.has_header) {
    while (std::getline(in, line)) {
      ++line_number;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (IsBlank(line)) continue;
      names = SplitFields(line, options.delimiter);
      break;
    }
    if (names.empty()) throw std::invalid_argument(where + ": expected a header row, got none");
    header_fields = static_cast<int>(names.size());
    if (!options.column_names.empty()) {
      if (options.column_names.size() != names.size()) {
        throw std::invalid_argument(
            where + ": column_names has " + std::to_string(options.column_names.size()) +
            " entries: expected " + std::to_string(names.size()) + " (the header's fields)");
      }
      names = options.column_names;
    }
  } else {
    names = options.column_names;
  }

  // Read all lines first: without a header the field count comes from the first data row.
  struct Row {
    int line;
    std::vector<std::string> fields;
  };
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (IsBlank(line)) continue;
    if (line.size() > kMaxCsvLineBytes) {
      throw std::invalid_argument(where + ": line " + std::to_string(line_number) +
                                  ": expected at most " + std::to_string(kMaxCsvLineBytes) +
                                  " characters, got " + std::to_string(line.size()));
    }
    rows.push_back({line_number, SplitFields(line, options.delimiter)});
    if (static_cast<int>(rows.back().fields.size()) > kMaxCsvFields) {
      throw std::invalid_argument(where + ": line " + std::to_string(line_number) +
                                  ": expected at most " + std::to_string(kMaxCsvFields) +
                                  " fields, got " + std::to_string(rows.back().fields.size()));
    }
  }
  if (header_fields < 0) {
    if (!names.empty()) {
      header_fields = static_cast<int>(names.size());
    } else if (!rows.empty()) {
      header_fields = static_cast<int>(rows.front().fields.size());
      if (header_fields > 1 && rows.front().fields.back().empty()) --header_fields;
      for (int j = 0; j < header_fields; ++j) names.push_back("c" + std::to_string(j));
    }
  }
  for (size_t j = 0; j < names.size(); ++j) {
    for (size_t i = 0; i < j; ++i) {
      if (names[i] == names[j] && !names[j].empty()) {
        throw std::invalid_argument(where + ": column name '" + names[j] +
                                    "' appears twice; expected unique names (give column_names)");
      }
    }
  }

  // Selection.
  std::vector<int> selected;
  std::vector<std::string> selected_names;
  if (options.columns.empty()) {
    for (int j = 0; j < static_cast<int>(names.size()); ++j) selected.push_back(j);
    selected_names = names;
  } else {
    for (const std::string& wanted : options.columns) {
      int found = -1;
      for (size_t j = 0; j < names.size(); ++j) {
        if (names[j] == wanted) found = static_cast<int>(j);
      }
      if (found < 0) {
        std::string message = where + ": no column '" + wanted + "'";
        const std::string hint = util::DidYouMean(wanted, names);
        if (!hint.empty()) message += "; did you mean '" + hint + "'?";
        throw std::invalid_argument(message + " (columns: " + JoinNames(names) + ")");
      }
      selected.push_back(found);
      selected_names.push_back(wanted);
    }
  }

  // Field-count check and parsing.
  const int ncols = static_cast<int>(selected.size());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::vector<double>> values;
  std::vector<int> lines;
  values.reserve(rows.size());
  int first_incomplete = -1;  // index into `values` of the first row with an empty selected cell
  int first_incomplete_line = 0;
  int first_incomplete_col = 0;
  for (const Row& row : rows) {
    std::vector<std::string> fields = row.fields;
    if (static_cast<int>(fields.size()) == header_fields + 1 && fields.back().empty()) {
      fields.pop_back();  // trailing delimiter
    }
    if (static_cast<int>(fields.size()) != header_fields) {
      throw std::invalid_argument(where + " line " + std::to_string(row.line) + ": expected " +
                                  std::to_string(header_fields) + " fields, got " +
                                  std::to_string(fields.size()));
    }
    std::vector<double> parsed(static_cast<size_t>(ncols));
    bool incomplete = false;
    for (int c = 0; c < ncols; ++c) {
      const int j = selected[static_cast<size_t>(c)];
      const std::string& cell = fields[static_cast<size_t>(j)];
      const std::string column_text =
          "column " + std::to_string(j + 1) + " ('" + names[static_cast<size_t>(j)] + "')";
      if (IsBlank(cell)) {
        if (options.empty_cells == CsvEmptyCells::kError) {
          throw std::invalid_argument(where + " line " + std::to_string(row.line) + ", " +
                                      column_text + ": expected a number, got an empty cell");
        }
        if (!incomplete && first_incomplete < 0) {
          first_incomplete_line = row.line;
          first_incomplete_col = j;
        }
        incomplete = true;
        parsed[static_cast<size_t>(c)] = nan;
        continue;
      }
      errno = 0;
      char* end = nullptr;
      const double v = std::strtod(cell.c_str(), &end);
      if (end == cell.c_str() || *end != '\0') {
        throw std::invalid_argument(where + " line " + std::to_string(row.line) + ", " +
                                    column_text + ": expected a number, got '" + cell + "'");
      }
      parsed[static_cast<size_t>(c)] = v;  // ERANGE: strtod returns +-HUGE_VAL or a denormal
    }
    if (incomplete && first_incomplete < 0) first_incomplete = static_cast<int>(values.size());
    if (!incomplete && first_incomplete >= 0 &&
        options.empty_cells == CsvEmptyCells::kDropTrailingRows) {
      throw std::invalid_argument(
          where + " line " + std::to_string(first_incomplete_line) + ", column " +
          std::to_string(first_incomplete_col + 1) + " ('" +
          names[static_cast<size_t>(first_incomplete_col)] +
          "'): expected a number, got an empty cell (only the last rows may be incomplete; line " +
          std::to_string(row.line) + " is complete again)");
    }
    values.push_back(std::move(parsed));
    lines.push_back(row.line);
  }
  if (options.empty_cells == CsvEmptyCells::kDropTrailingRows && first_incomplete >= 0) {
    values.resize(static_cast<size_t>(first_incomplete));
    lines.resize(static_cast<size_t>(first_incomplete));
  }

  CsvTable table;
  table.names = selected_names;
  table.lines = lines;
  table.data.resize(static_cast<Eigen::Index>(values.size()), ncols);
  for (size_t k = 0; k < values.size(); ++k) {
    for (int c = 0; c < ncols; ++c) {
      table.data(static_cast<Eigen::Index>(k), c) = values[k][static_cast<size_t>(c)];
    }
  }
  return table;
}

CsvTable ReadCsv(const std::string& path, const CsvOptions& options) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw std::invalid_argument("csv_file: '" + path + "': file not found");
  }
  // A device or a pipe (/dev/zero) never ends, and a file beyond the cap would not fit in
  // memory as text plus parsed rows: both refused before reading.
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw std::invalid_argument("csv_file: '" + path +
                                "': expected a regular file, got a directory, device or pipe");
  }
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  if (!ec && bytes > kMaxCsvBytes) {
    throw std::invalid_argument("csv_file: '" + path + "': expected at most " +
                                std::to_string(kMaxCsvBytes) + " bytes, got " +
                                std::to_string(bytes) + " (convert it to a .mat file)");
  }
  const std::optional<std::string> text = util::ReadWholeFile(path);
  if (!text) {
    throw std::invalid_argument("csv_file: '" + path + "': file exists but cannot be read");
  }
  return ParseCsv(*text, options, path);
}

}  // namespace graybox::estimators
