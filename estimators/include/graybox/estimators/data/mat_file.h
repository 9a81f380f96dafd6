// Reading and writing MATLAB .mat files (v5, compressed v7 and HDF5-based v7.3) through matio.
//
//   MatFile file("../shared/data/emps/DATA_EMPS.mat");   // throws when missing or unreadable
//   Eigen::MatrixXd qm = file.ReadMatrix("qm");          // 24841 x 1, double
//   double gtau = file.ReadScalar("gtau");
//   MatFile rec("rec_2020-10-21_10s_FF_A_08ms.mat");
//   Eigen::MatrixXd q = rec.ReadMatrix("rec.act_pos_mot_deg");   // struct field, 6 x 2501
//
// Variable paths: a top-level variable name, or a dotted path into nested 1x1 structs
// ("rec.act_pos_mot_deg", "para.u"). Struct arrays (more than one element) and cell arrays are not
// traversed.
//
// Numeric conversion: every real numeric class is read and converted to double: double, single
// (float32), int8/16/32/64, uint8/16/32/64 and logical. Values are converted with static_cast, so
// 64-bit integers above 2^53 lose their last bits. The matrix keeps MATLAB's shape: a variable of
// size r x c gives an r x c Eigen matrix (matio data are column-major, like Eigen). Empty variables
// give a 0 x 0 (or r x 0) matrix.
//
// Errors (all std::invalid_argument, naming the file):
// - the file does not exist or cannot be read: "... 'x.mat': file not found";
// - the file is not a MAT file matio can read: "...: expected a MATLAB .mat file (v4, v5, v7 or
//   v7.3), got a file matio cannot open";
// - a missing variable or struct field, with the closest name by edit distance:
//   "... has no variable 'qmm'; did you mean 'qm'? (variables: gtau, kp, kv, qg, qm, t, vir)";
// - a wrong type: "... variable 'traj_name': expected a real numeric 2-D array, got char 1x53"
//   (also for complex, sparse, cell, struct, function handles, and arrays of rank > 2);
// - a dotted path through something that is not a 1x1 struct.
// matio's own diagnostics are captured (never printed) and appended to the message when useful.
//
// A MatFile holds the file open and keeps the most recently read top-level variable decoded, so
// reading several fields of one struct decodes it once. It is movable, not copyable, and not safe
// to use from several threads at once (matio keeps a file position). Separate MatFile objects
// are independent.
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace graybox::estimators {

/// MAT file format versions matio reads and writes.
enum class MatVersion {
  kV4,   // MATLAB 4 (read only here)
  kV5,   // MATLAB 5 .. 7 (level 5 MAT-file)
  kV73,  // MATLAB 7.3 (HDF5)
};

/// What one variable (or struct field) holds, read without its data.
struct MatVariableInfo {
  std::string name;
  /// MATLAB class name: "double", "single", "int8" ... "uint64", "logical", "char", "struct",
  /// "cell", "sparse", "function_handle", "object", "opaque", "empty".
  std::string class_name;
  std::vector<std::size_t> dims;  // MATLAB size, at least 2 entries
  bool is_complex = false;
  /// Field names of a struct, in file order (empty otherwise).
  std::vector<std::string> fields;
  /// "double 24841x1", "struct 1x1 (12 fields)".
  std::string Describe() const;
};

class MatFile {
 public:
  /// Opens `path` read-only. Throws std::invalid_argument when it is missing or not a MAT file.
  explicit MatFile(const std::string& path);
  ~MatFile();
  MatFile(MatFile&&) noexcept;
  MatFile& operator=(MatFile&&) noexcept;
  MatFile(const MatFile&) = delete;
  MatFile& operator=(const MatFile&) = delete;

  const std::string& path() const { return path_; }
  MatVersion version() const;

  /// Top-level variables in file order (v7.3: HDF5's order, which is sorted by name) with class
  /// and size. Unnamed entries (MATLAB's __function_workspace__ and similar opaque blobs) are
  /// skipped.
  std::vector<MatVariableInfo> Variables() const;
  /// Names of the top-level variables, in the order of Variables().
  std::vector<std::string> VariableNames() const;
  /// Whether `variable_path` (a name or dotted struct path) exists.
  bool Has(const std::string& variable_path) const;
  /// Class, size and fields of a variable or struct field (same errors as ReadMatrix for missing
  /// names).
  MatVariableInfo Info(const std::string& variable_path) const;

  /// A real numeric variable or struct field converted to double, with MATLAB's r x c shape.
  Eigen::MatrixXd ReadMatrix(const std::string& variable_path) const;
  /// A numeric variable with exactly one element; std::invalid_argument naming the size otherwise.
  double ReadScalar(const std::string& variable_path) const;
  /// A char array as text (a 1 x n row; an r x n char matrix is read row by row, joined by '\n').
  std::string ReadString(const std::string& variable_path) const;

 private:
  struct Impl;
  std::string path_;
  std::unique_ptr<Impl> impl_;
};

/// Convenience: MatFile(path).ReadMatrix(variable_path).
Eigen::MatrixXd ReadMatMatrix(const std::string& path, const std::string& variable_path);

/// Storage class of a written numeric matrix.
enum class MatNumericClass {
  kDouble,
  kSingle,
  kInt8,
  kUInt8,
  kInt16,
  kUInt16,
  kInt32,
  kUInt32,
  kInt64,
  kUInt64,
};

/// Writes numeric matrices, structs of numeric matrices and strings to a new .mat file (for
/// results, fixtures and round-trip tests). Creating the writer truncates an existing file.
///
///   MatWriter w(dir + "/result.mat", MatVersion::kV73);
///   w.WriteMatrix("theta", theta);
///   w.WriteMatrix("u", u, MatNumericClass::kSingle);
///   w.WriteStruct("rec", {{"q", q}, {"tau", tau}});
///   w.Close();                      // also done by the destructor (which never throws)
///
/// Integer classes require every value to be an integer inside the class range, and kSingle
/// requires finite values to fit in float; otherwise std::invalid_argument names the variable,
/// the element and the value. Names must be valid MATLAB identifiers (letter first, then letters,
/// digits, '_'; at most 63 characters). kV4 cannot be written. `compress` applies zlib to v5
/// (making it a v7 file) and to v7.3 datasets. A v5 (and v7) file's 116-byte header text is fixed
/// ("MATLAB 5.0 MAT-file, written by graybox", no date), so that the same data make the same
/// bytes.
class MatWriter {
 public:
  MatWriter(const std::string& path, MatVersion version = MatVersion::kV5, bool compress = false);
  ~MatWriter();
  MatWriter(const MatWriter&) = delete;
  MatWriter& operator=(const MatWriter&) = delete;

  void WriteMatrix(const std::string& name, const Eigen::MatrixXd& value,
                   MatNumericClass storage = MatNumericClass::kDouble);
  /// A 1x1 struct whose fields (in map order, i.e. sorted by name) are numeric matrices.
  void WriteStruct(const std::string& name, const std::map<std::string, Eigen::MatrixXd>& fields,
                   MatNumericClass storage = MatNumericClass::kDouble);
  /// A 1 x n char array (ASCII).
  void WriteString(const std::string& name, const std::string& text);
  /// Flushes and closes the file; further writes throw std::logic_error.
  void Close();

 private:
  struct Impl;
  std::string path_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace graybox::estimators
