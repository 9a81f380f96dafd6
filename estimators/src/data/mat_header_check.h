// Private to mat_file.cc: a structural check of a MAT file's headers before matio reads them.
//
// matio trusts the sizes a file declares: a v5 dimensions sub-element claiming 3.3 GB made it
// allocate 6.6 GB for the dimensions alone while listing the variables (found by
// tests/fuzz/mat_fuzzer), and v4 records declare their name length and matrix size in the same
// way. MatHeaderDefect walks the file's structure the way matio will (MAT v5/v7: every top-level
// data element, miCOMPRESSED ones inflated with zlib up to the best compression ratio, and inside
// each miMATRIX the array flags, dimensions, name, and the parts, cells, struct fields or sparse
// indices its class has, recursively; MAT v4: every record's header) and checks that every size
// fits inside the element that holds it; in the HDF5-based v7.3 (mat73_check.cc), that every
// dataset's declared size fits in the storage HDF5 holds for it at deflate's best ratio (HDF5
// checks its own structures). The file is mapped read-only, so an uncompressed file's data pages
// are not read; each compressed variable is inflated once, one at a time.
#pragma once

#include <string>

namespace graybox::estimators::internal {

/// zlib's best compression ratio is about 1032:1: an element, dataset or variable that declares
/// more than this many times the bytes that hold it (plus kMaxCompressionSlackBytes, a small
/// object's chunk overhead) is corrupt.
inline constexpr double kMaxCompression = 1100.0;
inline constexpr double kMaxCompressionSlackBytes = 4096.0;

/// "" when the headers of the file at `path` are consistent (or it is not a MAT file at all, which
/// Mat_Open reports); otherwise the first defect, with its byte offset in the file ("element at
/// byte 248 (miMATRIX, 176 bytes): its dimensions sub-element declares 3309313544 bytes, 152
/// remain") or, in a v7.3 file, its dataset (Mat73Defect).
std::string MatHeaderDefect(const std::string& path);

/// The v7.3 check of MatHeaderDefect: "" when every dataset of the HDF5 file at `path` declares at
/// most 1100 times its storage (or the file's size) plus 4096 bytes, or when HDF5 cannot open it;
/// otherwise "dataset '/x' declares 1000000000000 elements of 8 bytes (...) in 0 bytes of
/// storage (the file has 4096)".
std::string Mat73Defect(const std::string& path);

}  // namespace graybox::estimators::internal
