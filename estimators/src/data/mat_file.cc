#include "graybox/estimators/data/mat_file.h"
#include "graybox/util/did_you_mean.h"
#include "mat_header_check.h"

#include <matio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "graybox/models/block.h"

namespace graybox::estimators {
namespace {

// matio reports problems through a global log function that prints to stderr by default. We
// route it into a per-thread buffer and append the text to our exceptions instead.
thread_local std::string t_matio_log;

void CaptureMatioLog(int /*log_level*/, char* message) {
  if (message == nullptr || t_matio_log.size() > 2000) return;
  if (!t_matio_log.empty()) t_matio_log += "; ";
  t_matio_log += message;
}

void InstallMatioLogger() {
  static std::once_flag once;
  std::call_once(once, [] { Mat_LogInitFunc("graybox", CaptureMatioLog); });
  t_matio_log.clear();
}

std::string MatioDetail() {
  if (t_matio_log.empty()) return "";
  return " (matio: " + t_matio_log + ")";
}

struct VarDeleter {
  void operator()(matvar_t* v) const { Mat_VarFree(v); }
};
using VarPtr = std::unique_ptr<matvar_t, VarDeleter>;

std::string ClassName(const matvar_t* v) {
  if (v->isLogical) return "logical";
  switch (v->class_type) {
    case MAT_C_EMPTY:
      return "empty";
    case MAT_C_CELL:
      return "cell";
    case MAT_C_STRUCT:
      return "struct";
    case MAT_C_OBJECT:
      return "object";
    case MAT_C_CHAR:
      return "char";
    case MAT_C_SPARSE:
      return "sparse";
    case MAT_C_DOUBLE:
      return "double";
    case MAT_C_SINGLE:
      return "single";
    case MAT_C_INT8:
      return "int8";
    case MAT_C_UINT8:
      return "uint8";
    case MAT_C_INT16:
      return "int16";
    case MAT_C_UINT16:
      return "uint16";
    case MAT_C_INT32:
      return "int32";
    case MAT_C_UINT32:
      return "uint32";
    case MAT_C_INT64:
      return "int64";
    case MAT_C_UINT64:
      return "uint64";
    case MAT_C_FUNCTION:
      return "function_handle";
    case MAT_C_OPAQUE:
      return "opaque";
  }
  return "unknown";
}

MatVariableInfo MakeInfo(matvar_t* v, const std::string& name) {
  MatVariableInfo info;
  info.name = name;
  info.class_name = ClassName(v);
  for (int r = 0; r < v->rank; ++r) info.dims.push_back(v->dims[r]);
  while (info.dims.size() < 2) info.dims.push_back(info.dims.empty() ? 0 : 1);
  info.is_complex = v->isComplex != 0;
  if (v->class_type == MAT_C_STRUCT) {
    const unsigned n = Mat_VarGetNumberOfFields(v);
    char* const* names = Mat_VarGetStructFieldnames(v);
    for (unsigned k = 0; k < n && names != nullptr; ++k) {
      info.fields.push_back(names[k] != nullptr ? names[k] : "");
    }
  }
  return info;
}

std::size_t NumElements(const matvar_t* v) {
  std::size_t n = 1;
  for (int r = 0; r < v->rank; ++r) n *= v->dims[r];
  return v->rank > 0 ? n : 0;
}

// The bytes reading `v` would allocate according to its header, as an upper bound (8 bytes per
// element of every numeric class, twice for complex; a struct or cell counts its element pointers
// and, recursively, its fields or cells as far as their headers were read): what a corrupt header
// can make matio allocate. In doubles, so that no product of declared sizes overflows.
double DeclaredBytes(const matvar_t* v, int depth = 0) {
  constexpr int kMaxDepth = 32;
  constexpr double kPointer = 8.0, kElement = 8.0;
  if (v == nullptr || depth > kMaxDepth) return 0.0;
  double elements = v->rank > 0 ? 1.0 : 0.0;
  for (int r = 0; r < v->rank; ++r) elements *= static_cast<double>(v->dims[r]);
  if (v->class_type == MAT_C_STRUCT || v->class_type == MAT_C_CELL) {
    const double per = v->class_type == MAT_C_STRUCT
                           ? static_cast<double>(Mat_VarGetNumberOfFields(const_cast<matvar_t*>(v)))
                           : 1.0;
    const double children = elements * per;
    double bytes = children * kPointer;
    // The children's headers (read with the parent's) are walked only when their count is sane;
    // a count beyond the limit is refused on its pointers alone.
    constexpr double kMaxChildren = 1e6;
    if (v->data != nullptr && children <= kMaxChildren) {
      const auto* const* items = static_cast<const matvar_t* const*>(v->data);
      for (std::size_t i = 0; i < static_cast<std::size_t>(children); ++i) {
        bytes += DeclaredBytes(items[i], depth + 1);
      }
    }
    return bytes;
  }
  return elements * kElement * (v->isComplex != 0 ? 2.0 : 1.0);
}

std::vector<std::string> SplitPath(const std::string& path) {
  std::vector<std::string> parts;
  std::string current;
  for (char c : path) {
    if (c == '.') {
      parts.push_back(current);
      current.clear();
    } else {
      current += c;
    }
  }
  parts.push_back(current);
  return parts;
}

std::string JoinNames(const std::vector<std::string>& names) {
  std::string out;
  for (size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += ", ";
    if (i == 40) {
      out += "... (" + std::to_string(names.size()) + " in all)";
      break;
    }
    out += names[i];
  }
  return out;
}

template <typename T>
void CopyAs(const matvar_t* v, Eigen::MatrixXd* out) {
  const T* data = static_cast<const T*>(v->data);
  double* dst = out->data();
  const Eigen::Index n = out->size();
  for (Eigen::Index i = 0; i < n; ++i) dst[i] = static_cast<double>(data[i]);
}

// Element type of the data matio hands back for a class (matio converts to the class type).
template <typename T>
bool SizeMatches(const matvar_t* v) {
  return v->data_size == static_cast<int>(sizeof(T));
}

bool IsNumericClass(matio_classes c) {
  return c == MAT_C_DOUBLE || c == MAT_C_SINGLE || c == MAT_C_INT8 || c == MAT_C_UINT8 ||
         c == MAT_C_INT16 || c == MAT_C_UINT16 || c == MAT_C_INT32 || c == MAT_C_UINT32 ||
         c == MAT_C_INT64 || c == MAT_C_UINT64;
}

}  // namespace

std::string MatVariableInfo::Describe() const {
  std::ostringstream os;
  if (is_complex) os << "complex ";
  os << class_name << " ";
  for (size_t i = 0; i < dims.size(); ++i) os << (i > 0 ? "x" : "") << dims[i];
  if (class_name == "struct") os << " (" << fields.size() << " fields)";
  return os.str();
}

// For a MAT v5/v7 file (not v4, not the HDF5-based v7.3): "" when its top-level data elements
// (8-byte tags: type, byte count; miMATRIX padded to 8 bytes, miCOMPRESSED not) end within the
// file, else where one runs past its end. matio stops listing variables at such an element, so a
// file cut inside its data would otherwise read as one that lacks the variables after the cut.
static std::string V5Truncation(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char header[128];
  if (!in.read(header, sizeof header)) return "";
  if (std::string(header, 10) != "MATLAB 5.0") return "";
  const bool swap = header[126] == 'M' && header[127] == 'I';
  auto u32 = [swap](const unsigned char* b) {
    return swap ? (std::uint32_t(b[0]) << 24 | std::uint32_t(b[1]) << 16 |
                   std::uint32_t(b[2]) << 8 | std::uint32_t(b[3]))
                : (std::uint32_t(b[3]) << 24 | std::uint32_t(b[2]) << 16 |
                   std::uint32_t(b[1]) << 8 | std::uint32_t(b[0]));
  };
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return "";
  constexpr std::uint32_t kMiMatrix = 14;
  std::uintmax_t pos = 128;
  int element = 0;
  while (pos + 8 <= size) {
    unsigned char tag[8];
    in.seekg(static_cast<std::streamoff>(pos));
    if (!in.read(reinterpret_cast<char*>(tag), 8)) return "";
    const std::uint32_t type = u32(tag);
    std::uintmax_t total = 8;
    if ((type >> 16) == 0) {
      total += u32(tag + 4);
      if (type == kMiMatrix) total = (total + 7) / 8 * 8;
    }
    ++element;
    if (pos + total > size) {
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "its data element %d at byte %ju declares %ju bytes, but the file ends at "
                    "byte %ju",
                    element, pos, total - 8, size);
      return buf;
    }
    pos += total;
  }
  return "";
}

struct MatFile::Impl {
  mat_t* mat = nullptr;
  std::vector<MatVariableInfo> variables;
  std::string truncation;  // V5Truncation of the file
  // DeclaredBytes of each top-level variable, from its header.
  std::map<std::string, double> declared_bytes;
  ~Impl() {
    cache.reset();  // free matio variables before their file (v7.3 variables hold HDF5 handles)
    if (mat != nullptr) Mat_Close(mat);
  }

  [[noreturn]] void Fail(const std::string& path, const std::string& what) const {
    throw std::invalid_argument("mat_file: '" + path + "': " + what);
  }

  // A numeric variable whose declared size could not fit in the file even at zlib's best
  // compression (about 1032:1) is a corrupt header: refused before matio allocates it (a 72 kB
  // file claiming 2e8 x 1 doubles took 4.7 GB).
  void CheckDeclaredSize(const std::string& path, const std::string& name) const {
    std::error_code ec;
    const double file_bytes = static_cast<double>(std::filesystem::file_size(path, ec));
    if (ec) return;
    for (const MatVariableInfo& info : variables) {
      if (info.name != name) continue;
      const auto it = declared_bytes.find(name);
      if (it == declared_bytes.end()) continue;
      const double declared = it->second;
      if (declared > internal::kMaxCompression * file_bytes + internal::kMaxCompressionSlackBytes) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "%.3g bytes in a file of %.3g bytes", declared, file_bytes);
        Fail(path, "truncated or corrupt MAT file: variable '" + name + "' declares " +
                       info.Describe() + ", " + buf);
      }
    }
  }

  // The most recently read top-level variable: reading several fields of one struct (compressed
  // v5 structs are decoded as a whole) then costs one read.
  mutable VarPtr cache;
  mutable std::string cache_name;

  // Reads the variable at a dotted path. The returned pointer points into `cache` (struct fields
  // belong to their parent) and stays valid until the next call.
  matvar_t* Resolve(const std::string& path, const std::string& variable_path) const {
    const std::vector<std::string> parts = SplitPath(variable_path);
    std::vector<std::string> names;
    bool found = false;
    for (const MatVariableInfo& info : variables) {
      names.push_back(info.name);
      found = found || info.name == parts[0];
    }
    if (!found && !truncation.empty()) {
      Fail(path, "truncated or corrupt MAT file: " + truncation + " (variable '" + parts[0] +
                     "' not found; readable before the cut: " + JoinNames(names) + ")");
    }
    if (!found) {
      std::string message = "has no variable '" + parts[0] + "'";
      const std::string hint = util::DidYouMean(parts[0], names);
      if (!hint.empty()) message += "; did you mean '" + hint + "'?";
      message += " (variables: " + JoinNames(names) + ")";
      Fail(path, message);
    }
    if (cache == nullptr || cache_name != parts[0]) {
      cache.reset();
      cache_name.clear();
      CheckDeclaredSize(path, parts[0]);
      InstallMatioLogger();
      cache.reset(Mat_VarRead(mat, parts[0].c_str()));
      if (cache == nullptr) {
        Fail(path, "cannot read variable '" + parts[0] + "'" + MatioDetail());
      }
      cache_name = parts[0];
    }
    matvar_t* current = cache.get();
    std::string walked = parts[0];
    for (size_t i = 1; i < parts.size(); ++i) {
      if (current->class_type != MAT_C_STRUCT) {
        Fail(path, "'" + walked + "' is " + MakeInfo(current, walked).Describe() +
                       ", not a struct: cannot read field '" + parts[i] + "' of it");
      }
      if (NumElements(current) != 1) {
        Fail(path, "'" + walked + "' is a " + MakeInfo(current, walked).Describe() +
                       " struct array: expected a 1x1 struct to read field '" + parts[i] + "'");
      }
      // The field looked up by hand: matio's Mat_VarGetStructFieldByName dereferences a field
      // name or the field array that a corrupt file left null (found by tests/fuzz/mat_fuzzer).
      matvar_t* field = nullptr;
      {
        const unsigned n = Mat_VarGetNumberOfFields(current);
        char* const* names = Mat_VarGetStructFieldnames(current);
        for (unsigned k = 0; k < n && names != nullptr && current->data != nullptr; ++k) {
          if (names[k] != nullptr && parts[i] == names[k]) {
            // matio's struct data: one matvar_t* per field (a 1x1 struct), nbytes in total.
            if (current->nbytes >= (k + 1) * sizeof(matvar_t*)) {
              field = static_cast<matvar_t**>(current->data)[k];
            }
            break;
          }
        }
      }
      if (field == nullptr) {
        const std::vector<std::string> fields = MakeInfo(current, walked).fields;
        std::string message = "struct '" + walked + "' has no field '" + parts[i] + "'";
        const std::string hint = util::DidYouMean(parts[i], fields);
        if (!hint.empty()) message += "; did you mean '" + hint + "'?";
        message += " (fields: " + JoinNames(fields) + ")";
        Fail(path, message);
      }
      current = field;
      walked += "." + parts[i];
    }
    return current;
  }
};

MatFile::MatFile(const std::string& path) : path_(path), impl_(std::make_unique<Impl>()) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    impl_->Fail(path, "file not found");
  }
  if (std::filesystem::is_directory(path, ec)) {
    impl_->Fail(path, "expected a MATLAB .mat file, got a directory");
  }
  if (!std::ifstream(path, std::ios::binary).good()) {
    impl_->Fail(path, "file exists but cannot be read (permissions?)");
  }
  // Sizes matio would allocate from its headers, checked first (mat_header_check.h).
  const std::string defect = internal::MatHeaderDefect(path);
  if (!defect.empty()) impl_->Fail(path, "truncated or corrupt MAT file: " + defect);
  InstallMatioLogger();
  impl_->mat = Mat_Open(path.c_str(), MAT_ACC_RDONLY);
  if (impl_->mat == nullptr) {
    impl_->Fail(path,
                "expected a MATLAB .mat file (v4, v5, v7 or v7.3), got a file matio cannot open" +
                    MatioDetail());
  }
  impl_->truncation = V5Truncation(path);
  Mat_Rewind(impl_->mat);
  while (true) {
    VarPtr v(Mat_VarReadNextInfo(impl_->mat));
    if (v == nullptr) break;
    // MATLAB stores an unnamed opaque "__function_workspace__" blob in some files; skip it.
    if (v->name == nullptr || v->name[0] == '\0') continue;
    impl_->variables.push_back(MakeInfo(v.get(), v->name));
    impl_->declared_bytes[v->name] = DeclaredBytes(v.get());
  }
  Mat_Rewind(impl_->mat);
}

MatFile::~MatFile() = default;
MatFile::MatFile(MatFile&&) noexcept = default;
MatFile& MatFile::operator=(MatFile&&) noexcept = default;

MatVersion MatFile::version() const {
  switch (Mat_GetVersion(impl_->mat)) {
    case MAT_FT_MAT73:
      return MatVersion::kV73;
    case MAT_FT_MAT4:
      return MatVersion::kV4;
    default:
      return MatVersion::kV5;
  }
}

std::vector<MatVariableInfo> MatFile::Variables() const { return impl_->variables; }

std::vector<std::string> MatFile::VariableNames() const {
  std::vector<std::string> names;
  for (const MatVariableInfo& info : impl_->variables) names.push_back(info.name);
  return names;
}

bool MatFile::Has(const std::string& variable_path) const {
  try {
    Info(variable_path);
    return true;
  } catch (const std::invalid_argument&) {
    return false;
  }
}

MatVariableInfo MatFile::Info(const std::string& variable_path) const {
  if (variable_path.find('.') == std::string::npos) {
    for (const MatVariableInfo& info : impl_->variables) {
      if (info.name == variable_path) return info;
    }
  }
  matvar_t* v = impl_->Resolve(path_, variable_path);
  return MakeInfo(v, variable_path);
}

Eigen::MatrixXd MatFile::ReadMatrix(const std::string& variable_path) const {
  matvar_t* v = impl_->Resolve(path_, variable_path);
  const MatVariableInfo info = MakeInfo(v, variable_path);
  auto wrong_type = [&](const std::string& why) {
    impl_->Fail(path_, "variable '" + variable_path + "': expected a real numeric 2-D array, got " +
                           info.Describe() + why);
  };
  if (v->class_type == MAT_C_EMPTY) return Eigen::MatrixXd(0, 0);
  if (!IsNumericClass(v->class_type)) wrong_type("");
  if (v->isComplex) wrong_type(" (take the real part in MATLAB before saving)");
  if (v->rank != 2) wrong_type(" (reshape to 2-D before saving)");
  const Eigen::Index rows = static_cast<Eigen::Index>(v->dims[0]);
  const Eigen::Index cols = static_cast<Eigen::Index>(v->dims[1]);
  Eigen::MatrixXd out(rows, cols);
  if (out.size() == 0) return out;
  if (v->data == nullptr) {
    impl_->Fail(path_, "variable '" + variable_path + "' (" + info.Describe() + ") has no data" +
                           MatioDetail());
  }
  bool size_ok = false;
  switch (v->class_type) {
    case MAT_C_DOUBLE:
      if ((size_ok = SizeMatches<double>(v))) CopyAs<double>(v, &out);
      break;
    case MAT_C_SINGLE:
      if ((size_ok = SizeMatches<float>(v))) CopyAs<float>(v, &out);
      break;
    case MAT_C_INT8:
      if ((size_ok = SizeMatches<std::int8_t>(v))) CopyAs<std::int8_t>(v, &out);
      break;
    case MAT_C_UINT8:
      if ((size_ok = SizeMatches<std::uint8_t>(v))) CopyAs<std::uint8_t>(v, &out);
      break;
    case MAT_C_INT16:
      if ((size_ok = SizeMatches<std::int16_t>(v))) CopyAs<std::int16_t>(v, &out);
      break;
    case MAT_C_UINT16:
      if ((size_ok = SizeMatches<std::uint16_t>(v))) CopyAs<std::uint16_t>(v, &out);
      break;
    case MAT_C_INT32:
      if ((size_ok = SizeMatches<std::int32_t>(v))) CopyAs<std::int32_t>(v, &out);
      break;
    case MAT_C_UINT32:
      if ((size_ok = SizeMatches<std::uint32_t>(v))) CopyAs<std::uint32_t>(v, &out);
      break;
    case MAT_C_INT64:
      if ((size_ok = SizeMatches<std::int64_t>(v))) CopyAs<std::int64_t>(v, &out);
      break;
    case MAT_C_UINT64:
      if ((size_ok = SizeMatches<std::uint64_t>(v))) CopyAs<std::uint64_t>(v, &out);
      break;
    default:
      break;
  }
  if (!size_ok) {
    impl_->Fail(path_, "variable '" + variable_path + "' (" + info.Describe() +
                           "): matio returned elements of " + std::to_string(v->data_size) +
                           " bytes, which does not match the class");
  }
  return out;
}

double MatFile::ReadScalar(const std::string& variable_path) const {
  const Eigen::MatrixXd m = ReadMatrix(variable_path);
  if (m.size() != 1) {
    std::ostringstream os;
    os << "variable '" << variable_path << "': expected a scalar (1x1), got " << m.rows() << "x"
       << m.cols();
    impl_->Fail(path_, os.str());
  }
  return m(0, 0);
}

std::string MatFile::ReadString(const std::string& variable_path) const {
  matvar_t* v = impl_->Resolve(path_, variable_path);
  if (v->class_type != MAT_C_CHAR || v->rank != 2) {
    impl_->Fail(path_, "variable '" + variable_path + "': expected a char array, got " +
                           MakeInfo(v, variable_path).Describe());
  }
  const std::size_t rows = v->dims[0];
  const std::size_t cols = v->dims[1];
  if (rows == 0 || cols == 0 || v->data == nullptr) return "";
  // The data matio read must hold every character the dimensions declare (a corrupt file's data
  // element can be shorter: found by tests/fuzz/mat_fuzzer).
  const double needed = static_cast<double>(rows) * static_cast<double>(cols) *
                        static_cast<double>(std::max(v->data_size, 1));
  if ((v->data_size != 1 && v->data_size != 2 && v->data_size != 4) ||
      needed > static_cast<double>(v->nbytes)) {
    impl_->Fail(path_, "truncated or corrupt MAT file: variable '" + variable_path + "' (" +
                           MakeInfo(v, variable_path).Describe() + ") holds " +
                           std::to_string(v->nbytes) + " bytes of characters of " +
                           std::to_string(v->data_size) + " bytes each");
  }
  auto at = [&](std::size_t i) -> char {
    std::uint32_t code = 0;
    if (v->data_size == 1) code = static_cast<const std::uint8_t*>(v->data)[i];
    if (v->data_size == 2) code = static_cast<const std::uint16_t*>(v->data)[i];
    if (v->data_size == 4) code = static_cast<const std::uint32_t*>(v->data)[i];
    return code < 128 ? static_cast<char>(code) : '?';
  };
  std::string out;
  for (std::size_t r = 0; r < rows; ++r) {
    if (r > 0) out += '\n';
    for (std::size_t c = 0; c < cols; ++c) out += at(r + rows * c);  // column-major
  }
  return out;
}

Eigen::MatrixXd ReadMatMatrix(const std::string& path, const std::string& variable_path) {
  return MatFile(path).ReadMatrix(variable_path);
}

// ---------------------------------------------------------------------------------------------
// Writing

namespace {

bool IsIdentifier(const std::string& name) {
  if (name.empty() || name.size() > 63) return false;
  if (!std::isalpha(static_cast<unsigned char>(name[0]))) return false;
  for (char c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  }
  return true;
}

// A typed copy of a matrix, checking that each value is representable in T.
template <typename T>
std::vector<T> Convert(const std::string& path, const std::string& name, const Eigen::MatrixXd& m) {
  std::vector<T> out(static_cast<size_t>(m.size()));
  for (Eigen::Index i = 0; i < m.size(); ++i) {
    const double v = m.data()[i];
    bool ok = true;
    if constexpr (std::is_integral_v<T>) {
      // The largest 64-bit values are not exactly representable as double; compare against the
      // power of two just above the range so the cast is defined.
      const double hi = std::ldexp(1.0, std::numeric_limits<T>::digits);
      const double lo = std::is_signed_v<T> ? -hi : 0.0;
      ok = std::isfinite(v) && v == std::floor(v) && v >= lo && v < hi;
    } else if constexpr (std::is_same_v<T, float>) {
      ok = !std::isfinite(v) || std::abs(v) <= std::numeric_limits<float>::max();
    }
    if (!ok) {
      std::ostringstream os;
      os.precision(10);
      os << "mat_file: '" << path << "': variable '" << name << "' element " << i << " (row "
         << i % std::max<Eigen::Index>(m.rows(), 1) << ", column "
         << i / std::max<Eigen::Index>(m.rows(), 1) << "): expected a value representable in the "
         << "storage class, got " << v;
      throw std::invalid_argument(os.str());
    }
    out[static_cast<size_t>(i)] = static_cast<T>(v);
  }
  return out;
}

// Creates a matio variable holding a typed copy of `m` (matio copies the data; the caller frees).
matvar_t* CreateNumeric(const std::string& path, const std::string& name, const Eigen::MatrixXd& m,
                        MatNumericClass storage) {
  size_t dims[2] = {static_cast<size_t>(m.rows()), static_cast<size_t>(m.cols())};
  auto make = [&](matio_classes c, matio_types t, auto values) {
    return Mat_VarCreate(name.c_str(), c, t, 2, dims, values.data(), 0);
  };
  switch (storage) {
    case MatNumericClass::kDouble:
      return make(MAT_C_DOUBLE, MAT_T_DOUBLE, Convert<double>(path, name, m));
    case MatNumericClass::kSingle:
      return make(MAT_C_SINGLE, MAT_T_SINGLE, Convert<float>(path, name, m));
    case MatNumericClass::kInt8:
      return make(MAT_C_INT8, MAT_T_INT8, Convert<std::int8_t>(path, name, m));
    case MatNumericClass::kUInt8:
      return make(MAT_C_UINT8, MAT_T_UINT8, Convert<std::uint8_t>(path, name, m));
    case MatNumericClass::kInt16:
      return make(MAT_C_INT16, MAT_T_INT16, Convert<std::int16_t>(path, name, m));
    case MatNumericClass::kUInt16:
      return make(MAT_C_UINT16, MAT_T_UINT16, Convert<std::uint16_t>(path, name, m));
    case MatNumericClass::kInt32:
      return make(MAT_C_INT32, MAT_T_INT32, Convert<std::int32_t>(path, name, m));
    case MatNumericClass::kUInt32:
      return make(MAT_C_UINT32, MAT_T_UINT32, Convert<std::uint32_t>(path, name, m));
    case MatNumericClass::kInt64:
      return make(MAT_C_INT64, MAT_T_INT64, Convert<std::int64_t>(path, name, m));
    case MatNumericClass::kUInt64:
      return make(MAT_C_UINT64, MAT_T_UINT64, Convert<std::uint64_t>(path, name, m));
  }
  return nullptr;
}

}  // namespace

struct MatWriter::Impl {
  mat_t* mat = nullptr;
  matio_compression compression = MAT_COMPRESSION_NONE;

  void Write(const std::string& path, matvar_t* raw, const std::string& name) {
    VarPtr v(raw);
    if (v == nullptr) {
      throw std::runtime_error("mat_file: '" + path + "': cannot create variable '" + name + "'" +
                               MatioDetail());
    }
    if (Mat_VarWrite(mat, v.get(), compression) != 0) {
      throw std::runtime_error("mat_file: '" + path + "': writing variable '" + name + "' failed" +
                               MatioDetail());
    }
  }
};

MatWriter::MatWriter(const std::string& path, MatVersion version, bool compress)
    : path_(path), impl_(std::make_unique<Impl>()) {
  if (version == MatVersion::kV4) {
    throw std::invalid_argument("mat_file: '" + path +
                                "': expected MatVersion::kV5 or kV73 for writing, got kV4");
  }
  InstallMatioLogger();
  // A fixed header text in v5 (matio's default holds the date), so that the same data make the
  // same bytes; v7.3 keeps matio's own (HDF5 stamps its objects with times anyway).
  impl_->mat = Mat_CreateVer(
      path.c_str(),
      version == MatVersion::kV73 ? nullptr : "MATLAB 5.0 MAT-file, written by graybox",
      version == MatVersion::kV73 ? MAT_FT_MAT73 : MAT_FT_MAT5);
  if (impl_->mat == nullptr) {
    throw std::invalid_argument("mat_file: '" + path +
                                "': cannot create the file (missing directory or no permission?)" +
                                MatioDetail());
  }
  impl_->compression = compress ? MAT_COMPRESSION_ZLIB : MAT_COMPRESSION_NONE;
}

MatWriter::~MatWriter() {
  if (impl_ != nullptr && impl_->mat != nullptr) Mat_Close(impl_->mat);
}

namespace {
void CheckName(const std::string& path, const std::string& name) {
  if (!IsIdentifier(name)) {
    throw std::invalid_argument("mat_file: '" + path + "': expected a MATLAB identifier (letter, " +
                                "then letters, digits or '_', at most 63 characters), got '" +
                                name + "'");
  }
}
}  // namespace

void MatWriter::WriteMatrix(const std::string& name, const Eigen::MatrixXd& value,
                            MatNumericClass storage) {
  if (impl_->mat == nullptr) throw std::logic_error("mat_file: MatWriter used after Close()");
  CheckName(path_, name);
  InstallMatioLogger();
  impl_->Write(path_, CreateNumeric(path_, name, value, storage), name);
}

void MatWriter::WriteStruct(const std::string& name,
                            const std::map<std::string, Eigen::MatrixXd>& fields,
                            MatNumericClass storage) {
  if (impl_->mat == nullptr) throw std::logic_error("mat_file: MatWriter used after Close()");
  CheckName(path_, name);
  std::vector<const char*> field_names;
  for (const auto& [field, value] : fields) {
    CheckName(path_, field);
    field_names.push_back(field.c_str());
  }
  InstallMatioLogger();
  size_t dims[2] = {1, 1};
  VarPtr s(Mat_VarCreateStruct(name.c_str(), 2, dims, field_names.data(),
                               static_cast<unsigned>(field_names.size())));
  if (s == nullptr) {
    throw std::runtime_error("mat_file: '" + path_ + "': cannot create struct '" + name + "'" +
                             MatioDetail());
  }
  for (const auto& [field, value] : fields) {
    matvar_t* f = CreateNumeric(path_, name + "." + field, value, storage);
    if (f == nullptr) {
      throw std::runtime_error("mat_file: '" + path_ + "': cannot create field '" + name + "." +
                               field + "'" + MatioDetail());
    }
    // The struct takes ownership of the field variable.
    Mat_VarSetStructFieldByName(s.get(), field.c_str(), 0, f);
  }
  impl_->Write(path_, s.release(), name);
}

void MatWriter::WriteString(const std::string& name, const std::string& text) {
  if (impl_->mat == nullptr) throw std::logic_error("mat_file: MatWriter used after Close()");
  CheckName(path_, name);
  InstallMatioLogger();
  size_t dims[2] = {1, text.size()};
  std::string copy = text;
  impl_->Write(path_, Mat_VarCreate(name.c_str(), MAT_C_CHAR, MAT_T_UINT8, 2, dims, copy.data(), 0),
               name);
}

void MatWriter::Close() {
  if (impl_->mat == nullptr) return;
  const int status = Mat_Close(impl_->mat);
  impl_->mat = nullptr;
  if (status != 0) {
    throw std::runtime_error("mat_file: '" + path_ + "': closing the file failed" + MatioDetail());
  }
}

}  // namespace graybox::estimators
