// Hostile data files are refused before they exhaust memory (issue 12): a device given as a CSV
// file (/dev/zero never ends), a CSV line or field count beyond the caps, and a MAT file (v4, v5
// or the HDF5-based v7.3) whose header declares far more data than the file could hold at any
// compression.
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <hdf5.h>

#include "graybox/estimators/data/csv_file.h"
#include "graybox/estimators/data/mat_file.h"

namespace graybox::estimators {
namespace {

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no error)";
}

std::string TempFile(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("graybox_hostile_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

TEST(HostileFiles, ADeviceIsNotReadAsACsvFile) {
  const std::string e = ErrorOf([] { ReadCsv("/dev/zero", {}); });
  EXPECT_NE(e.find("'/dev/zero': expected a regular file"), std::string::npos) << e;
}

TEST(HostileFiles, CsvLinesAndFieldsAreCapped) {
  const std::string long_line = "a,b\n" + std::string(kMaxCsvLineBytes + 1, '1') + ",2\n";
  const std::string e = ErrorOf([&] { ParseCsv(long_line, {}, "long.csv"); });
  EXPECT_NE(e.find("line 2: expected at most 1048576 characters"), std::string::npos) << e;
  std::string wide = "x\n";
  for (int k = 0; k <= kMaxCsvFields; ++k) wide += "1,";
  wide += "1\n";
  const std::string f = ErrorOf([&] {
    CsvOptions o;
    o.has_header = false;
    ParseCsv(wide, o, "wide.csv");
  });
  EXPECT_NE(f.find("expected at most 10000 fields"), std::string::npos) << f;
}

// A MAT v5 file with one double variable 'vir' whose header declares 2e8 x 1 elements
// (1.6 GB) and which ends after the header: refused as corrupt before matio allocates.
// A real MAT file cut inside its data (a copy of the EMPS record's first half): matio lists the
// variables before the cut only, which read as "has no variable 'vir'"; it is a truncated file.
TEST(HostileFiles, AMatFileCutInsideItsDataIsTruncated) {
  const std::string source = std::string(GRAYBOX_SHARED_DATA_DIR) + "/emps/DATA_EMPS.mat";
  std::ifstream in(source, std::ios::binary);
  ASSERT_TRUE(in.good()) << source;
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string whole = TempFile("whole.mat"), cut = TempFile("cut.mat");
  for (const auto& [path, size] :
       {std::make_pair(whole, bytes.size()), std::make_pair(cut, bytes.size() / 2)}) {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(size));
  }
  const std::vector<std::string> names = MatFile(whole).VariableNames();
  ASSERT_FALSE(names.empty());
  const std::string last = names.back();  // stored after the middle of the file
  EXPECT_EQ(ErrorOf([&] { MatFile(whole).ReadMatrix(last); }), "(no error)");
  const std::string e = ErrorOf([&] { MatFile(cut).ReadMatrix(last); });
  std::filesystem::remove(whole);
  std::filesystem::remove(cut);
  EXPECT_NE(e.find("truncated or corrupt MAT file: its data element"), std::string::npos) << e;
  EXPECT_NE(e.find("but the file ends at byte " + std::to_string(bytes.size() / 2)),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("variable '" + last + "' not found"), std::string::npos) << e;
}

TEST(HostileFiles, AMatHeaderThatClaimsMoreThanTheFileHoldsIsCorrupt) {
  std::vector<char> bytes(128, ' ');
  const char text[] = "MATLAB 5.0 MAT-file, hostile header test";
  std::memcpy(bytes.data(), text, sizeof(text) - 1);
  for (int k = 116; k < 124; ++k) bytes[k] = 0;  // subsystem offset
  bytes[124] = 0x00;
  bytes[125] = 0x01;  // version 0x0100 (little-endian)
  bytes[126] = 'I';
  bytes[127] = 'M';
  auto put32 = [&](std::uint32_t v) {
    for (int k = 0; k < 4; ++k) bytes.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
  };
  constexpr std::uint32_t kMiInt8 = 1, kMiInt32 = 5, kMiUint32 = 6, kMiDouble = 9, kMiMatrix = 14,
                          kDoubleClass = 6;
  constexpr std::uint32_t kRows = 200000000, kDataBytes = kRows * 8u;
  put32(kMiMatrix);
  put32(16 + 16 + 16 + 8 + kDataBytes);  // flags, dims, name, data tag, data
  put32(kMiUint32);
  put32(8);
  put32(kDoubleClass);
  put32(0);
  put32(kMiInt32);
  put32(8);
  put32(kRows);
  put32(1);
  put32(kMiInt8);
  put32(3);
  bytes.insert(bytes.end(), {'v', 'i', 'r', 0, 0, 0, 0, 0});
  put32(kMiDouble);
  put32(kDataBytes);
  bytes.insert(bytes.end(), 64, 0);  // a few values, then the file ends
  const std::string path = TempFile("claims.mat");
  {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  const std::string e = ErrorOf([&] { MatFile(path).ReadMatrix("vir"); });
  std::filesystem::remove(path);
  EXPECT_NE(e.find("truncated or corrupt MAT file: variable 'vir' declares double 200000000x1"),
            std::string::npos)
      << e;
}

// matio allocates a numeric array from its class and dimensions (here double, 1e5 x 1e5: 80 GB)
// before it reads the data element; a data element of no numeric type (type 0, 8 bytes) passed
// the size check, which counts elements against the bytes of a known type only.
TEST(HostileFiles, ANumericArrayWhoseDataHasNoNumericTypeIsCorrupt) {
  std::vector<char> bytes(128, ' ');
  const char text[] = "MATLAB 5.0 MAT-file, data of no numeric type";
  std::memcpy(bytes.data(), text, sizeof(text) - 1);
  for (int k = 116; k < 124; ++k) bytes[k] = 0;
  bytes[124] = 0x00;
  bytes[125] = 0x01;
  bytes[126] = 'I';
  bytes[127] = 'M';
  auto put32 = [&](std::uint32_t v) {
    for (int k = 0; k < 4; ++k) bytes.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
  };
  constexpr std::uint32_t kMiInt32 = 5, kMiUint32 = 6, kMiMatrix = 14, kDoubleClass = 6;
  put32(kMiMatrix);
  put32(16 + 16 + 8 + 16);  // flags, dims, a small name, the data tag and 8 bytes
  put32(kMiUint32);
  put32(8);
  put32(kDoubleClass);
  put32(0);
  put32(kMiInt32);
  put32(8);
  put32(100000);
  put32(100000);
  put32(1u | 1u << 16);  // a small miINT8 element of 1 byte: the name "x"
  bytes.insert(bytes.end(), {'x', 0, 0, 0});
  put32(0);  // data type 0
  put32(8);
  bytes.insert(bytes.end(), 8, 0);
  const std::string path = TempFile("type0.mat");
  {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  const std::string e = ErrorOf([&] { MatFile(path).ReadMatrix("x"); });
  std::filesystem::remove(path);
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 128 (miMATRIX, 56 bytes): its "
                   "dimensions declare 10000000000 elements, its real part has data type 0, not "
                   "a numeric one"),
            std::string::npos)
      << e;
}

// Found by tests/fuzz/mat_fuzzer (the inputs are in tests/fuzz/regressions/): matio allocated
// what a corrupt header declared. An 887-byte v5 file whose struct field declares a name of 2048
// bytes made it allocate 6.4 GB on reading the struct; a 1,912-byte file whose dimensions
// sub-element declares 3.3 GB made it allocate 6.6 GB while listing the variables. The headers are
// now walked before matio opens the file (mat_header_check.h).
TEST(HostileFiles, MatHeadersThatClaimMoreThanTheirElementsHoldAreCorrupt) {
  const std::string dir = GRAYBOX_SOURCE_DIR "/tests/fuzz/regressions/";
  std::string e = ErrorOf([&] { MatFile(dir + "mat_struct_field_declares_6gb.mat"); });
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 584 (miMATRIX, 304 bytes): "
                   "struct field 1: its name sub-element declares 2048 bytes, 76 remain"),
            std::string::npos)
      << e;
  e = ErrorOf([&] { MatFile(dir + "mat_dimensions_declare_3gb.mat"); });
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 248 (miMATRIX, 176 bytes): its "
                   "dimensions sub-element declares 3309313544 bytes, 152 remain"),
            std::string::npos)
      << e;
  // An opaque-class variable (cut) whose next sub-element declares 4.2 GB: matio reads it as the
  // dimensions (8.3 GB allocated).
  e = ErrorOf([&] { MatFile(dir + "mat_opaque_dimensions_4gb.mat"); });
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 432 (miMATRIX, 100663376 "
                   "bytes): its dimensions (opaque class) sub-element declares 4160749576 bytes, "
                   "76 remain"),
            std::string::npos)
      << e;
  // An 89-byte v4 file whose sparse record declares 1.28e9 rows and no columns (matio sized it by
  // its rows: 5.1 GB).
  e = ErrorOf([&] { MatFile(dir + "mat_v4_sparse_rows_1e9.mat"); });
  EXPECT_NE(e.find("truncated or corrupt MAT file: v4 record 1 at byte 0: a sparse record of "
                   "1280590157 x 0 (expected at least 1 row and 3 or 4 columns)"),
            std::string::npos)
      << e;
  // Array flags whose tag declares 43 bytes: matio reads the flags as 16 bytes and the dimensions
  // right after them, a tag declaring 1.7 GB there (3.4 GB allocated).
  e = ErrorOf([&] { MatFile(dir + "mat_flags_43_bytes_dimensions_3gb.mat"); });
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 248 (miMATRIX, 176 bytes): its "
                   "array flags are not 8 bytes of miUINT32 (the tag declares 43 bytes of type 6)"),
            std::string::npos)
      << e;
  // A struct field whose name sub-element declares 1 byte: matio skips 8 bytes for a field's
  // name tag and read the name's bytes as the data tag (1.7 GB of int32).
  e = ErrorOf([&] { MatFile(dir + "mat_struct_field_name_then_data_2gb.mat"); });
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 584 (miMATRIX, 304 bytes): "
                   "struct field 1: its name sub-element declares 1 bytes (a cell or struct field "
                   "has an empty name)"),
            std::string::npos)
      << e;
  // A function-handle variable whose dimensions sub-element declares 10 bytes: matio takes two
  // dimensions from it (10 / 4, rounded down) and allocated a pointer per element (480 TB).
  e = ErrorOf([&] { MatFile(dir + "mat_function_class_dimensions_10_bytes.mat"); });
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 128 (miMATRIX, 112 bytes): its "
                   "dimensions declare 60727182684003 elements of an opaque class, 29 bytes "
                   "remain"),
            std::string::npos)
      << e;
  // An uncompressed opaque variable whose first sub-element is int64: matio reads only its tag
  // and the name's tag from its data, a miINT8 name of 4.1 GB there.
  e = ErrorOf([&] { MatFile(dir + "mat_opaque_int64_dimensions_name_4gb.mat"); });
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 584 (miMATRIX, 304 bytes): its "
                   "name (opaque class, read from the data after the dimensions tag) sub-element "
                   "declares 4127195136 bytes, 181 remain"),
            std::string::npos)
      << e;
  // A struct whose name tag has type 256 (not miINT8) and declares 115 bytes: matio reads only
  // the tag and the field names right after it, whose tag declares 12,482 fields of 4 bytes for a
  // struct of 65,792 elements (6.6 GB of pointers); the walk had skipped the 115 bytes.
  e = ErrorOf([&] { MatFile(dir + "mat_name_of_type_256_struct_fields_6gb.mat"); });
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 584 (miMATRIX, 304 bytes): its "
                   "field names sub-element declares 49928 bytes, 105 remain"),
            std::string::npos)
      << e;
  // An empty top-level miMATRIX followed by stray elements, one a dimensions tag of 4.3 GB:
  // matio read the empty element's headers from the bytes after it (8.6 GB allocated).
  e = ErrorOf([&] { MatFile(dir + "mat_empty_variable_then_dimensions_4gb.mat"); });
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 248 (miMATRIX, 0 bytes): too "
                   "short for a variable's flags, dimensions and name"),
            std::string::npos)
      << e;
}

// Found by tests/fuzz/mat_fuzzer: a compressed variable whose zlib stream fails its check value;
// matio read the headers it inflated before the failure and allocated 1.4 TB (an allocation
// AddressSanitizer refuses).
TEST(HostileFiles, ACompressedVariableZlibRejectsIsCorrupt) {
  const std::string e = ErrorOf([&] {
    MatFile(GRAYBOX_SOURCE_DIR "/tests/fuzz/regressions/mat_compressed_bad_check_value.mat");
  });
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 217 (miCOMPRESSED, 99 bytes): "
                   "its zlib stream is corrupt (incorrect data check)"),
            std::string::npos)
      << e;
}

// Found by tests/fuzz/mat_fuzzer: a struct whose field names matio left null (inflated from a
// corrupt zlib stream); its Mat_VarGetStructFieldByName dereferenced them (a segmentation fault).
// The stream is now refused when the file is opened, and graybox looks struct fields up itself.
TEST(HostileFiles, AStructWithoutFieldNamesIsRefused) {
  const std::string e = ErrorOf([&] {
    MatFile(GRAYBOX_SOURCE_DIR "/tests/fuzz/regressions/mat_struct_field_name_null.mat")
        .ReadMatrix("s.x");
  });
  EXPECT_NE(e.find("truncated or corrupt MAT file: element at byte 432 (miCOMPRESSED, 126 bytes): "
                   "its zlib stream is corrupt"),
            std::string::npos)
      << e;
}

// The header check maps regular files only: a device given as a MAT file is not read to its end
// (/dev/zero never ends) but refused by matio's own header test.
// A v7.3 (HDF5) MAT file whose dataset declares 1e12 doubles (8 TB) in a chunked, deflated layout
// with no chunk written: matio would allocate the declared size before reading; the check
// refuses it, naming the dataset. A real v7.3 file of zeros compressed about 1000:1 still reads.
TEST(HostileFiles, AV73DatasetThatDeclaresMoreThanItsStorageIsCorrupt) {
  const std::string path = TempFile("v73_declares_8tb.mat");
  {
    const hid_t fcpl = H5Pcreate(H5P_FILE_CREATE);
    H5Pset_userblock(fcpl, 512);  // MATLAB's 128-byte header lives in a 512-byte user block
    const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, fcpl, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    const hsize_t dims[2] = {1000000, 1000000};
    const hsize_t chunk[2] = {1, 1000};
    const hid_t space = H5Screate_simple(2, dims, nullptr);
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 2, chunk);
    H5Pset_deflate(dcpl, 6);
    const hid_t dataset =
        H5Dcreate2(file, "x", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    ASSERT_GE(dataset, 0);
    const hid_t text = H5Tcopy(H5T_C_S1);
    H5Tset_size(text, 6);
    const hid_t scalar = H5Screate(H5S_SCALAR);
    const hid_t attribute =
        H5Acreate2(dataset, "MATLAB_class", text, scalar, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(attribute, text, "double");
    H5Aclose(attribute);
    H5Sclose(scalar);
    H5Tclose(text);
    H5Dclose(dataset);
    H5Pclose(dcpl);
    H5Sclose(space);
    H5Fclose(file);
    H5Pclose(fcpl);
    std::vector<char> header(128, ' ');
    const char title[] = "MATLAB 7.3 MAT-file, hostile v7.3 test";
    std::memcpy(header.data(), title, sizeof(title) - 1);
    std::memset(header.data() + 116, 0, 8);
    header[124] = 0x00;  // version 0x0200, little-endian with "IM"
    header[125] = 0x02;
    header[126] = 'I';
    header[127] = 'M';
    std::fstream out(path, std::ios::binary | std::ios::in | std::ios::out);
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
  }
  const std::string e = ErrorOf([&] { MatFile(path).ReadMatrix("x"); });
  std::filesystem::remove(path);
  EXPECT_NE(e.find("truncated or corrupt MAT file: dataset '/x' declares 1000000000000 elements "
                   "of 8 bytes (8000000000000 bytes) in 0 bytes of storage"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find(path), std::string::npos) << e;

  const std::string zeros = TempFile("v73_zeros.mat");
  {
    MatWriter w(zeros, MatVersion::kV73, /*compress=*/true);
    w.WriteMatrix("z", Eigen::MatrixXd::Zero(1000, 1000));
  }
  Eigen::MatrixXd z;
  EXPECT_EQ(ErrorOf([&] { z = MatFile(zeros).ReadMatrix("z"); }), "(no error)");
  std::filesystem::remove(zeros);
  EXPECT_EQ(z.rows(), 1000);
  EXPECT_EQ(z.cols(), 1000);
  EXPECT_EQ(z.cwiseAbs().maxCoeff(), 0.0);
}

TEST(HostileFiles, ADeviceIsNotReadAsAMatFile) {
  const std::string e = ErrorOf([] { MatFile("/dev/zero"); });
  EXPECT_NE(e.find("expected a MATLAB .mat file (v4, v5, v7 or v7.3)"), std::string::npos) << e;
}

// Every input tests/fuzz/mat_fuzzer found (tests/fuzz/regressions/*.mat, docs/fuzzing.md) is
// refused when the file is opened or read, with a located error, before matio allocates what its
// headers claim (the test process would be killed or crash otherwise).
TEST(HostileFiles, EveryMatFuzzerFindingIsRefused) {
  int files = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(GRAYBOX_SOURCE_DIR "/tests/fuzz/regressions")) {
    if (entry.path().extension() != ".mat") continue;
    ++files;
    std::string e;
    e += ErrorOf([&] {
      const MatFile mat(entry.path().string());
      for (const std::string& name : mat.VariableNames()) {
        e += ErrorOf([&] { mat.ReadMatrix(name); }) + "\n";
        e += ErrorOf([&] { mat.ReadString(name); }) + "\n";
      }
      e += ErrorOf([&] { mat.ReadMatrix("s.x"); }) + "\n";
    });
    EXPECT_NE(e.find("truncated or corrupt MAT file"), std::string::npos)
        << entry.path() << ": " << e;
  }
  EXPECT_GE(files, 17);
  // A char array whose data element holds fewer characters than its dimensions: ReadString read
  // past matio's buffer. Its data element has type 37, no numeric type: refused at opening now
  // (ReadString still checks the bytes matio read against the dimensions).
  const std::string e = ErrorOf(
      [] { MatFile(GRAYBOX_SOURCE_DIR "/tests/fuzz/regressions/mat_char_data_short.mat"); });
  EXPECT_NE(e.find("its dimensions declare 268435456 elements, its real part has data type 37, "
                   "not a numeric one"),
            std::string::npos)
      << e;
}

}  // namespace
}  // namespace graybox::estimators
