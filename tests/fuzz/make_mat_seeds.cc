// Writes the seed corpus of mat_fuzzer into the folder given as the only argument: small MAT
// files in the versions the harness reads (v5 and v5 compressed, i.e. v7; not the HDF5-based
// v7.3) with a double matrix, an integer matrix, single values, a struct of channels and a char
// array, as the loaders meet them.
#include <cstdio>
#include <exception>
#include <string>

#include <Eigen/Core>

#include "graybox/estimators/data/mat_file.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_mat_seeds DIR\n");
    return 2;
  }
  namespace est = graybox::estimators;
  const std::string dir = argv[1];
  try {
    struct Version {
      const char* name;
      est::MatVersion version;
      bool compress;
    };
    for (const Version& v : {Version{"v5", est::MatVersion::kV5, false},
                             Version{"v5_compressed", est::MatVersion::kV5, true}}) {
      est::MatWriter w(dir + "/seed_" + v.name + ".mat", v.version, v.compress);
      Eigen::MatrixXd t(8, 1), q(8, 2);
      for (int k = 0; k < 8; ++k) {
        t(k) = 0.001 * k;
        q(k, 0) = 0.1 * k;
        q(k, 1) = -0.05 * k * k;
      }
      w.WriteMatrix("t", t);
      w.WriteMatrix("q", q);
      w.WriteMatrix("counts", Eigen::MatrixXd::Constant(2, 3, 7.0), est::MatNumericClass::kInt32);
      w.WriteMatrix("gain", Eigen::MatrixXd::Constant(1, 1, 35.15), est::MatNumericClass::kSingle);
      w.WriteStruct("s", {{"x", q.col(0)}, {"y", q.col(1)}});
      w.WriteString("label", "EMPS seed");
      w.Close();
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_mat_seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
