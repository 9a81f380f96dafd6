// Private to mat_file.cc: a structural check of a MAT file's headers before matio reads them.
//
// matio trusts the sizes a file declares: a v5 dimensions sub-element claiming 3.3 GB made it
// allocate 6.6 GB for the dimensions alone while listing the variables (found by
// tests/fuzz/mat_fuzzer), and v4 records declare their name length and matrix size in the same
// way. MatHeaderDefect walks the file's structure the way matio will (MAT v5/v7: every top-level
// data element, miCOMPRESSED ones inflated with zlib up to the best compression ratio, and inside
// each miMATRIX the array flags, dimensions, name, and the parts, cells, struct fields or sparse
// indices its class has, recursively; MAT v4: every record's header) and checks that every size
// fits inside the element that holds it. The HDF5-based v7.3 is left to HDF5's own checks. The
// file is mapped read-only, so an uncompressed file's data pages are not read; each compressed
// variable is inflated once, one at a time.
#pragma once

#include <string>

namespace graybox::estimators::internal {

/// "" when the headers of the file at `path` are consistent (or it is v7.3, or not a MAT file at
/// all, which Mat_Open reports); otherwise the first defect, with its byte offset in the file
/// ("element at byte 248 (miMATRIX, 176 bytes): its dimensions sub-element declares 3309313544
/// bytes, 152 remain").
std::string MatHeaderDefect(const std::string& path);

}  // namespace graybox::estimators::internal
