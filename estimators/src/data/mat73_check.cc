// The v7.3 part of MatHeaderDefect (mat_header_check.h): every dataset's declared size against
// the storage HDF5 holds for it. matio allocates a v7.3 variable's declared size (its dataspace's
// points times the element size) before it reads a byte, so a 72 kB file whose dataspace claims
// 1e12 doubles would make it ask for 8 TB. A dataset's storage (HDF5's H5Dget_storage_size: the
// contiguous block, or the chunks written, compressed) can be smaller than its data only by the
// filter's compression, which for deflate is at most about 1032:1, and no storage is larger than
// the file; a dataset beyond that ratio is corrupt (or never written: its fill value is not data a
// MATLAB file holds).
#include <hdf5.h>
#include <sys/stat.h>

#include <cstdint>
#include <string>

#include "mat_header_check.h"

namespace graybox::estimators::internal {
namespace {

struct Visit {
  double file_bytes = 0.0;
  std::string defect;
};

// H5Ovisit's callback: every object of the file, once; datasets are checked.
herr_t CheckObject(hid_t root, const char* name, const H5O_info_t* info, void* data) {
  auto* visit = static_cast<Visit*>(data);
  if (info->type != H5O_TYPE_DATASET) return 0;
  const hid_t dataset = H5Dopen2(root, name, H5P_DEFAULT);
  if (dataset < 0) return 0;  // matio will say what is wrong with it
  const hid_t space = H5Dget_space(dataset);
  const hid_t type = H5Dget_type(dataset);
  if (space >= 0 && type >= 0) {
    const hssize_t points = H5Sget_simple_extent_npoints(space);
    const std::size_t element = H5Tget_size(type);
    const double declared = static_cast<double>(points) * static_cast<double>(element);
    const double storage = static_cast<double>(H5Dget_storage_size(dataset));
    const double held = storage < visit->file_bytes ? storage : visit->file_bytes;
    if (points < 0 || declared > kMaxCompression * held + kMaxCompressionSlackBytes) {
      visit->defect = "dataset '/" + std::string(name) + "' declares " +
                      std::to_string(static_cast<long long>(points)) + " elements of " +
                      std::to_string(element) + " bytes (" +
                      std::to_string(static_cast<long long>(declared)) + " bytes) in " +
                      std::to_string(static_cast<long long>(storage)) +
                      " bytes of storage (the file has " +
                      std::to_string(static_cast<long long>(visit->file_bytes)) + ")";
    }
  }
  if (type >= 0) H5Tclose(type);
  if (space >= 0) H5Sclose(space);
  H5Dclose(dataset);
  return visit->defect.empty() ? 0 : 1;  // a positive value stops the visit
}

}  // namespace

std::string Mat73Defect(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return "";
  Visit visit;
  visit.file_bytes = static_cast<double>(st.st_size);
  // HDF5's own error stack printing is off while the file is walked (a file HDF5 cannot open is
  // left to matio's message).
  H5E_BEGIN_TRY {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (file >= 0) {
      H5Ovisit1(file, H5_INDEX_NAME, H5_ITER_NATIVE, CheckObject, &visit);
      H5Fclose(file);
    }
  }
  H5E_END_TRY;
  return visit.defect;
}

}  // namespace graybox::estimators::internal
