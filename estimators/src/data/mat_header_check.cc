#include "mat_header_check.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace graybox::estimators::internal {
namespace {

// MAT v5 data types and array classes (MATLAB's "MAT-File Format", 2023, tables 1-2 and 1-3).
constexpr std::uint32_t kMiInt8 = 1, kMiUInt8 = 2, kMiInt16 = 3, kMiUInt16 = 4, kMiInt32 = 5,
                        kMiUInt32 = 6, kMiSingle = 7, kMiDouble = 9, kMiInt64 = 12, kMiUInt64 = 13,
                        kMiMatrix = 14, kMiCompressed = 15, kMiUtf8 = 16, kMiUtf16 = 17,
                        kMiUtf32 = 18;
constexpr std::uint32_t kCellClass = 1, kStructClass = 2, kObjectClass = 3, kSparseClass = 5,
                        kCharClass = 4, kUInt64Class = 15, kFunctionClass = 16, kOpaqueClass = 17;
// The smallest top-level variable: array flags (16 bytes), two dimensions (16), a small name (8).
constexpr std::size_t kMinVariableBytes = 40;
// Nesting of cells and structs matio recurses through.
constexpr int kMaxDepth = 32;

std::size_t TypeSize(std::uint32_t type) {
  switch (type) {
    case kMiInt8:
    case kMiUInt8:
    case kMiUtf8:
      return 1;
    case kMiInt16:
    case kMiUInt16:
    case kMiUtf16:
      return 2;
    case kMiInt32:
    case kMiUInt32:
    case kMiSingle:
    case kMiUtf32:
      return 4;
    case kMiDouble:
    case kMiInt64:
    case kMiUInt64:
      return 8;
    default:
      return 0;
  }
}

const char* TypeName(std::uint32_t type) {
  switch (type) {
    case kMiMatrix:
      return "miMATRIX";
    case kMiCompressed:
      return "miCOMPRESSED";
    default:
      return "data element";
  }
}

// Read-only bytes: a mapped file or an inflated element.
struct Bytes {
  const unsigned char* p = nullptr;
  std::size_t n = 0;
  const unsigned char* data() const { return p; }
  std::size_t size() const { return n; }
  unsigned char operator[](std::size_t i) const { return p[i]; }
};

// A v5 byte stream (the file, or one inflated miCOMPRESSED element) and the file offset of its
// first byte (for messages; inflated bytes are reported at their element's offset).
class V5Walker {
 public:
  V5Walker(Bytes bytes, bool swap, std::size_t file_offset, bool inflated)
      : b_(bytes), swap_(swap), file_offset_(file_offset), inflated_(inflated) {}

  // Checks the elements in [pos, end); "" or the first defect.
  std::string Elements(std::size_t pos, std::size_t end) {
    while (pos + 8 <= end && pos + 8 <= b_.size()) {
      Tag t;
      if (!ReadTag(pos, &t)) return "";
      const std::size_t element_end = pos + t.header + t.bytes;
      const std::size_t next =
          t.small ? pos + 8 : pos + 8 + (t.type == kMiCompressed ? t.bytes : Padded(t.bytes));
      std::string defect;
      // A variable is a miMATRIX (or, not inside an inflated one, a miCOMPRESSED miMATRIX) with
      // room for its flags (16 bytes), dimensions (16) and name (8): matio reads the headers of
      // anything else as if they were one, past the element's end.
      if (t.small || !(t.type == kMiMatrix || (t.type == kMiCompressed && !inflated_))) {
        defect = "not a variable (a miMATRIX" + std::string(inflated_ ? "" : " or miCOMPRESSED") +
                 " element), type " + std::to_string(t.type);
      } else if (t.type == kMiMatrix && t.bytes < kMinVariableBytes) {
        defect = "too short for a variable's flags, dimensions and name (at least " +
                 std::to_string(kMinVariableBytes) + " bytes)";
      } else if (t.type == kMiMatrix) {
        defect = Matrix(pos + 8, element_end, 0);
      } else if (t.type == kMiCompressed && !t.small && !inflated_) {
        defect = Compressed(pos + 8, element_end, pos);
      }
      if (!defect.empty()) {
        return Where(pos) + " (" + TypeName(t.type) + ", " + std::to_string(t.bytes) +
               " bytes): " + defect;
      }
      if (next <= pos) return "";
      pos = next;
    }
    return "";
  }

 private:
  struct Tag {
    std::uint32_t type = 0;
    std::size_t bytes = 0;
    std::size_t header = 8;  // bytes before the data: 8, or 4 for a small element
    bool small = false;
  };

  std::uint32_t U32(std::size_t at) const {
    const unsigned char* p = b_.data() + at;
    return swap_ ? (std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 |
                    std::uint32_t(p[2]) << 8 | std::uint32_t(p[3]))
                 : (std::uint32_t(p[3]) << 24 | std::uint32_t(p[2]) << 16 |
                    std::uint32_t(p[1]) << 8 | std::uint32_t(p[0]));
  }
  static std::size_t Padded(std::size_t n) { return (n + 7) / 8 * 8; }
  std::string Where(std::size_t pos) const {
    return inflated_ ? "inflated byte " + std::to_string(pos)
                     : "element at byte " + std::to_string(file_offset_ + pos);
  }

  // False when the tag is not inside the bytes (a file cut there: V5Truncation's business).
  bool ReadTag(std::size_t pos, Tag* t) const {
    if (pos + 8 > b_.size()) return false;
    const std::uint32_t first = U32(pos);
    *t = Tag{};
    if ((first >> 16) != 0) {
      t->small = true;
      t->type = first & 0xffff;
      t->bytes = first >> 16;
      t->header = 4;
    } else {
      t->type = first;
      t->bytes = U32(pos + 4);
    }
    return true;
  }

  // One sub-element at `pos` inside a matrix ending (as declared) at `end`: its tag must be in
  // the bytes, and a sub-element matio allocates when it lists the variable (`header_part`: the
  // dimensions, the name, field names) must end within the bytes that exist, a data part within
  // the declared matrix. Sets *next to the following sub-element.
  std::string Sub(std::size_t pos, std::size_t end, const char* what, bool header_part, Tag* t,
                  std::size_t* next, bool* cut) const {
    *cut = false;
    if (pos + 8 > end) {
      return std::string("no room for its ") + what + " (" + std::to_string(end - pos) +
             " bytes remain)";
    }
    if (!ReadTag(pos, t)) {
      *cut = true;
      return "";
    }
    const std::size_t limit = header_part ? std::min(end, b_.size()) : end;
    const std::size_t data = pos + t->header;
    if (t->bytes > limit - std::min(limit, data)) {
      return std::string("its ") + what + " sub-element declares " + std::to_string(t->bytes) +
             " bytes, " + std::to_string(limit - std::min(limit, data)) + " remain";
    }
    *next = t->small ? pos + 8 : pos + 8 + Padded(t->bytes);
    return "";
  }

  std::string Matrix(std::size_t pos, std::size_t end, int depth) {
    if (depth > kMaxDepth)
      return "cells or structs nested deeper than " + std::to_string(kMaxDepth);
    if (pos == end) return "";  // an empty matrix (an empty struct field or cell)
    Tag t;
    std::size_t next = pos;
    bool cut = false;
    std::string d = Sub(pos, end, "array flags", true, &t, &next, &cut);
    if (!d.empty() || cut) return d;
    // matio reads the flags as 16 bytes (tag and two words) whatever the tag declares, and the
    // dimensions right after them: any other size would put the two readings apart.
    if (t.small || t.bytes != 8 || t.type != kMiUInt32) {
      return "its array flags are not 8 bytes of miUINT32 (the tag declares " +
             std::to_string(t.bytes) + " bytes of type " + std::to_string(t.type) + ")";
    }
    const std::uint32_t array_class = U32(pos + 8) & 0xff;
    const bool complex = (U32(pos + 8) & 0x800) != 0;
    const std::uint32_t nzmax = U32(pos + 12);
    pos = next;
    // Function handles and opaque objects (MATLAB's classdef "MCOS" objects) have no dimensions
    // after their flags, but their name; matio reads the two sub-elements after the flags as
    // dimensions and name all the same, so both must fit in the element too. The rest is opaque.
    // Where that sub-element holds dimensions, matio allocates one pointer per element from them.
    if (array_class == kFunctionClass || array_class == kOpaqueClass) {
      d = Sub(pos, end, "dimensions (opaque class)", true, &t, &next, &cut);
      if (!d.empty() || cut) return d;
      // In an uncompressed variable, matio reads only the tag of a sub-element there that is not
      // miINT32 (MATLAB's is the variable's name) and the name's tag from its first data bytes:
      // where those bytes make a miINT8 tag, the name it declares must fit too.
      if (t.type != kMiInt32 && !t.small && !inflated_) {
        const std::size_t at = pos + 8;
        if (at + 8 <= b_.size() && U32(at) == kMiInt8) {
          return Sub(at, end, "name (opaque class, read from the data after the dimensions tag)",
                     true, &t, &next, &cut);
        }
        return "";
      }
      // matio takes bytes / 4 dimensions, rounded down, whatever the remainder.
      if (t.type == kMiInt32) {
        double count = 1.0;
        for (std::size_t k = 0; k < t.bytes / 4 && pos + t.header + 4 * k + 4 <= b_.size(); ++k) {
          count *= static_cast<std::int32_t>(U32(pos + t.header + 4 * k));
        }
        const std::size_t available = std::min(end, b_.size()) - std::min(next, b_.size());
        if (count < 0.0 || count * 8.0 > static_cast<double>(available)) {
          char buf[160];
          std::snprintf(buf, sizeof buf,
                        "its dimensions declare %.0f elements of an opaque class, %zu bytes remain",
                        count, available);
          return buf;
        }
      }
      return Sub(next, end, "name (opaque class)", true, &t, &next, &cut);
    }
    d = Sub(pos, end, "dimensions", true, &t, &next, &cut);
    if (!d.empty() || cut) return d;
    if (t.type != kMiInt32 || t.bytes % 4 != 0 || t.bytes < 8) {
      return "its dimensions are not at least two miINT32 values";
    }
    double elements = 1.0;
    for (std::size_t k = 0; k < t.bytes / 4; ++k) {
      const std::size_t at = pos + t.header + 4 * k;
      if (at + 4 > b_.size()) return "";
      const auto dim = static_cast<std::int32_t>(U32(at));
      if (dim < 0) return "dimension " + std::to_string(k + 1) + " is negative";
      elements *= dim;
    }
    pos = next;
    // matio reads a name only from a miINT8 element (or one packed in its tag); of a tag of any
    // other type it reads the 8 bytes of the tag alone, whatever size it declares, and takes what
    // follows as the next part.
    if (ReadTag(pos, &t) && !t.small && t.type != kMiInt8 && pos + 8 <= end) {
      next = pos + 8;
    } else {
      d = Sub(pos, end, "name", true, &t, &next, &cut);
      if (!d.empty() || cut) return d;
    }
    // A cell or struct field has an empty name: matio skips 8 bytes for its name tag and reads
    // the data right after, whatever the tag declares.
    if (depth > 0 && !t.small && t.bytes != 0) {
      return "its name sub-element declares " + std::to_string(t.bytes) +
             " bytes (a cell or struct field has an empty name)";
    }
    pos = next;
    // What follows the name by class: the parts of numeric, char and logical arrays; the indices
    // and values of sparse ones; cells; struct and object fields.
    if (array_class == kCellClass) return Children(pos, end, elements, depth, "cell");
    if (array_class == kStructClass || array_class == kObjectClass) {
      if (array_class == kObjectClass) {
        d = Sub(pos, end, "class name", true, &t, &next, &cut);
        if (!d.empty() || cut) return d;
        pos = next;
      }
      d = Sub(pos, end, "field name length", true, &t, &next, &cut);
      if (!d.empty() || cut) return d;
      // matio reads it as one small element (type and value in 8 bytes).
      if (!t.small || t.bytes != 4 || pos + t.header + 4 > b_.size()) {
        return "its field name length is not one miINT32";
      }
      const std::uint32_t length = U32(pos + t.header);
      pos = next;
      d = Sub(pos, end, "field names", true, &t, &next, &cut);
      if (!d.empty() || cut) return d;
      if (length == 0 && t.bytes > 0) return "its field names have a length of 0";
      const double fields = length == 0 ? 0.0 : static_cast<double>(t.bytes / length);
      return Children(next, end, elements * fields, depth, "struct field");
    }
    const std::size_t parts = complex ? 2 : 1;
    if (array_class == kSparseClass) {
      // Row indices (nzmax), column starts (columns + 1), values (and imaginary values); matio
      // sizes its arrays from these tags, so each must lie in the bytes that exist, the indices
      // be 4-byte integers and the values of a numeric type.
      const std::size_t available = std::min(end, b_.size()) - std::min(pos, b_.size());
      if (static_cast<double>(nzmax) * 4.0 > static_cast<double>(available)) {
        return "its nzmax " + std::to_string(nzmax) + " does not fit in the " +
               std::to_string(available) + " bytes that remain";
      }
      static const char* const kSparseParts[] = {"row indices", "column starts", "values",
                                                 "imaginary values"};
      for (std::size_t k = 0; k < 2 + parts; ++k) {
        d = Sub(pos, end, kSparseParts[k], true, &t, &next, &cut);
        if (!d.empty() || cut) return d;
        const bool index = k < 2;
        if (index ? TypeSize(t.type) != 4 || t.type == kMiSingle || t.type == kMiUtf32
                  : TypeSize(t.type) == 0 || t.type == kMiUtf8 || t.type == kMiUtf16 ||
                        t.type == kMiUtf32) {
          return std::string("its ") + kSparseParts[k] + " have data type " +
                 std::to_string(t.type);
        }
        pos = next;
      }
      return "";
    }
    for (std::size_t k = 0; k < parts; ++k) {
      d = Sub(pos, end, k == 0 ? "real part" : "imaginary part", false, &t, &next, &cut);
      if (!d.empty() || cut) return d;
      const std::size_t size = TypeSize(t.type);
      // matio allocates a numeric or char array from its class and dimensions before it reads
      // the data; data of no numeric type cannot fill it.
      const bool numeric = array_class >= kCharClass && array_class <= kUInt64Class;
      if (numeric && size == 0 && elements > 0.0) {
        char buf[160];
        std::snprintf(buf, sizeof buf,
                      "its dimensions declare %.0f elements, its %s has data type %u, not a "
                      "numeric one",
                      elements, k == 0 ? "real part" : "imaginary part", t.type);
        return buf;
      }
      if (size > 0 && elements * static_cast<double>(size) > static_cast<double>(t.bytes)) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "its dimensions declare %.0f elements, its %s holds %zu",
                      elements, k == 0 ? "real part" : "imaginary part", t.bytes / size);
        return buf;
      }
      pos = next;
    }
    return "";
  }

  // `count` miMATRIX children (cells or struct fields) from `pos`, each with at least its tag.
  std::string Children(std::size_t pos, std::size_t end, double count, int depth,
                       const char* what) {
    if (count * 8.0 > static_cast<double>(end - std::min(end, pos))) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "it declares %.0f %ss, which cannot fit in its %zu bytes",
                    count, what, end - std::min(end, pos));
      return buf;
    }
    for (std::size_t k = 0; k < static_cast<std::size_t>(count); ++k) {
      Tag t;
      if (!ReadTag(pos, &t)) return "";
      if (t.small || t.type != kMiMatrix) {
        return std::string("its ") + what + " " + std::to_string(k + 1) + " is not a miMATRIX";
      }
      if (t.bytes > end - std::min(end, pos + 8)) {
        return std::string("its ") + what + " " + std::to_string(k + 1) + " declares " +
               std::to_string(t.bytes) + " bytes, " + std::to_string(end - std::min(end, pos + 8)) +
               " remain";
      }
      const std::string d = Matrix(pos + 8, pos + 8 + t.bytes, depth + 1);
      if (!d.empty()) return std::string(what) + " " + std::to_string(k + 1) + ": " + d;
      pos += 8 + Padded(t.bytes);
    }
    return "";
  }

  // Inflates the zlib stream in [pos, end) (up to kMaxCompression times its size) and checks the
  // element inside.
  std::string Compressed(std::size_t pos, std::size_t end, std::size_t element) {
    const std::size_t available = std::min(end, b_.size()) - std::min(pos, b_.size());
    const double cap = kMaxCompression * static_cast<double>(available) + kMaxCompressionSlackBytes;
    std::vector<unsigned char> out;
    z_stream z{};
    if (inflateInit(&z) != Z_OK) return "";
    z.next_in = const_cast<unsigned char*>(b_.data() + pos);
    z.avail_in = static_cast<uInt>(available);
    unsigned char chunk[65536];
    int status = Z_OK;
    while (status == Z_OK) {
      z.next_out = chunk;
      z.avail_out = sizeof chunk;
      status = inflate(&z, Z_NO_FLUSH);
      out.insert(out.end(), chunk, chunk + (sizeof chunk - z.avail_out));
      if (static_cast<double>(out.size()) > cap) {
        inflateEnd(&z);
        return "it inflates to more than " + std::to_string(static_cast<long long>(cap)) +
               " bytes (beyond zlib's best compression of its " + std::to_string(available) +
               " bytes)";
      }
      if (status == Z_BUF_ERROR && z.avail_in == 0) break;  // cut: matio stops there too
    }
    const std::string zlib_message = z.msg != nullptr ? z.msg : "";
    inflateEnd(&z);
    // A stream zlib rejects (a wrong check value, an invalid code) is corrupt, whatever it
    // inflated first: matio reads the variable's headers from those bytes all the same.
    if (status != Z_STREAM_END && status != Z_OK && status != Z_BUF_ERROR) {
      return "its zlib stream is corrupt (" +
             (zlib_message.empty() ? "status " + std::to_string(status) : zlib_message) + ")";
    }
    V5Walker inner(Bytes{out.data(), out.size()}, swap_, element, true);
    return inner.Elements(0, out.size());
  }

  Bytes b_;
  bool swap_;
  std::size_t file_offset_;
  bool inflated_;
};

// MAT v4: records of a 20-byte header (type MOPT, rows, columns, imaginary flag, name length),
// the name, and the data.
std::string V4Defect(Bytes b) {
  std::size_t pos = 0;
  int record = 0;
  while (pos + 20 <= b.size()) {
    ++record;
    auto i32 = [&](std::size_t at, bool big) {
      const unsigned char* p = b.data() + at;
      const std::uint32_t v = big ? (std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 |
                                     std::uint32_t(p[2]) << 8 | std::uint32_t(p[3]))
                                  : (std::uint32_t(p[3]) << 24 | std::uint32_t(p[2]) << 16 |
                                     std::uint32_t(p[1]) << 8 | std::uint32_t(p[0]));
      return static_cast<std::int32_t>(v);
    };
    // As matio reads it: the type is byte-swapped when it is out of range, and then its
    // thousands digit M (0: little-endian, 1: big-endian) sets the order of the other fields.
    std::int32_t type = i32(pos, false);
    if (type < 0 || type > 4052) type = i32(pos, true);
    if (type < 0 || type >= 2000) return "";  // not a v4 record matio reads: Mat_Open decides
    const bool big = type >= 1000;
    const std::int32_t rows = i32(pos + 4, big), cols = i32(pos + 8, big);
    const std::int32_t imaginary = i32(pos + 12, big), name = i32(pos + 16, big);
    const int precision = (type / 10) % 10, matrix_type = type % 10;
    static const double kSize[] = {8, 4, 4, 2, 2, 1};
    const double size = precision <= 5 ? kSize[precision] : 8.0;
    // A sparse record (type 2) holds (nonzeros + 1) rows of at least 3 columns (i, j, value);
    // matio sizes it by its rows whatever the columns say.
    const double columns = matrix_type == 2 ? std::max(cols, 3) : cols;
    const double data = static_cast<double>(rows) * columns * size * (imaginary != 0 ? 2.0 : 1.0);
    const double left = static_cast<double>(b.size() - pos - 20);
    char buf[240];
    // A sparse record holds nonzeros + 1 >= 1 rows of 3 (real) or 4 (complex) columns; matio
    // sizes it from rows - 1.
    if (matrix_type == 2 && (rows < 1 || cols < 3 || cols > 4)) {
      std::snprintf(buf, sizeof buf,
                    "v4 record %d at byte %zu: a sparse record of %d x %d (expected at least 1 "
                    "row and 3 or 4 columns)",
                    record, pos, rows, cols);
      return buf;
    }
    if (rows < 0 || cols < 0 || name < 0 || static_cast<double>(name) > left ||
        static_cast<double>(rows) > left || static_cast<double>(cols) > left) {
      std::snprintf(buf, sizeof buf,
                    "v4 record %d at byte %zu: declares %d x %d with a name of %d bytes, %.0f "
                    "bytes remain",
                    record, pos, rows, cols, name, left);
      return buf;
    }
    if (data > left - name) {
      std::snprintf(buf, sizeof buf,
                    "v4 record %d at byte %zu: declares %d x %d (%.0f bytes of data), %.0f bytes "
                    "remain",
                    record, pos, rows, cols, data, left - name);
      return buf;
    }
    pos += 20 + static_cast<std::size_t>(name) + static_cast<std::size_t>(data);
  }
  return "";
}

// A regular file mapped read-only (only the pages the walk touches are read); empty when the
// path is not a regular file or cannot be mapped (Mat_Open then reports it).
class MappedFile {
 public:
  explicit MappedFile(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return;
    struct stat st {};
    if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0) {
      void* p =
          ::mmap(nullptr, static_cast<std::size_t>(st.st_size), PROT_READ, MAP_PRIVATE, fd, 0);
      if (p != MAP_FAILED) {
        bytes_.p = static_cast<const unsigned char*>(p);
        bytes_.n = static_cast<std::size_t>(st.st_size);
      }
    }
    ::close(fd);
  }
  ~MappedFile() {
    if (bytes_.p != nullptr) ::munmap(const_cast<unsigned char*>(bytes_.p), bytes_.n);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  Bytes bytes() const { return bytes_; }

 private:
  Bytes bytes_;
};

}  // namespace

std::string MatHeaderDefect(const std::string& path) {
  const MappedFile file(path);
  const Bytes bytes = file.bytes();
  if (bytes.size() == 0) return "";
  // matio's own test: a 128-byte header ending in the version (0x0100: v5/v7, 0x0200: v7.3) and
  // the endian indicator "IM" (or "MI", byte-swapped).
  if (bytes.size() >= 128) {
    const bool im = bytes[126] == 'I' && bytes[127] == 'M';
    const bool mi = bytes[126] == 'M' && bytes[127] == 'I';
    const unsigned version = im ? (bytes[125] << 8 | bytes[124]) : (bytes[124] << 8 | bytes[125]);
    if ((im || mi) && version == 0x0200) return Mat73Defect(path);  // v7.3: HDF5
    if ((im || mi) && version == 0x0100) {
      V5Walker walker(bytes, mi, 0, false);
      return walker.Elements(128, bytes.size());
    }
  }
  return V4Defect(bytes);
}

}  // namespace graybox::estimators::internal
