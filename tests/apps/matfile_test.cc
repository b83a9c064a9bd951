#include "apps/matfile.h"

#include <gtest/gtest.h>
#include <matio.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace fesim {
namespace {

/// Reads variable `name` of a .mat file (null when absent); the caller frees it.
struct MatFile {
  mat_t* mat;
  explicit MatFile(const std::string& path) : mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY)) {}
  ~MatFile() {
    if (mat != nullptr) Mat_Close(mat);
  }
  std::vector<double> Doubles(const std::string& name, std::size_t* rows = nullptr,
                              std::size_t* cols = nullptr) {
    matvar_t* v = Mat_VarRead(mat, name.c_str());
    if (v == nullptr) return {};
    const double* d = static_cast<const double*>(v->data);
    std::vector<double> out(d, d + v->dims[0] * v->dims[1]);
    if (rows != nullptr) *rows = v->dims[0];
    if (cols != nullptr) *cols = v->dims[1];
    Mat_VarFree(v);
    return out;
  }
  std::string Text(matvar_t* v) {
    return std::string(static_cast<const char*>(v->data), v->dims[1]);
  }
  std::string Text(const std::string& name) {
    matvar_t* v = Mat_VarRead(mat, name.c_str());
    const std::string s = v == nullptr ? "" : Text(v);
    if (v != nullptr) Mat_VarFree(v);
    return s;
  }
  std::vector<std::string> Cell(const std::string& name) {
    matvar_t* v = Mat_VarRead(mat, name.c_str());
    std::vector<std::string> out;
    if (v == nullptr) return out;
    for (std::size_t k = 0; k < v->dims[0] * v->dims[1]; ++k)
      out.push_back(Text(Mat_VarGetCell(v, k)));
    Mat_VarFree(v);
    return out;
  }
};

std::string Dir(const std::string& name) {
  const std::string d = ::testing::TempDir() + name;
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

TEST(MatFile, ADiscreteModelHasTheIdpolyAndIdnlhwFields) {
  identification::DiscreteModel m;
  m.sample_time_s = 0.02;
  m.inputs = {"u.ext", "u.flex"};
  m.input_units = {"us", "us"};
  m.output = "q.wrist_flexion";
  m.output_unit = "rad";
  m.a = {1.0, -1.6, 0.64};
  m.b = {{0.0, 0.1, 0.2}, {0.0, 0.3}};
  m.nonlinearity_u = {{0.0, 150.0, 300.0}};
  m.nonlinearity_f = {{0.0, 0.5, 1.0}};
  m.output_offset = 0.05;
  const std::string path = Dir("mat_model") + "/model.mat";
  WriteDiscreteModelMat(m, path);
  MatFile f(path);
  ASSERT_NE(f.mat, nullptr);
  EXPECT_EQ(f.Doubles("Ts"), std::vector<double>{0.02});
  EXPECT_EQ(f.Doubles("A"), m.a);
  std::size_t rows = 0, cols = 0;
  // B: one row per input, padded with zeros, column-major.
  EXPECT_EQ(f.Doubles("B", &rows, &cols), (std::vector<double>{0.0, 0.0, 0.1, 0.3, 0.2, 0.0}));
  EXPECT_EQ(rows, 2u);
  EXPECT_EQ(cols, 3u);
  EXPECT_EQ(f.Doubles("F"), std::vector<double>{1.0});
  EXPECT_EQ(f.Doubles("C"), std::vector<double>{1.0});
  EXPECT_EQ(f.Doubles("Breakpoints", &rows, &cols),
            (std::vector<double>{0.0, 0.0, 150.0, 0.5, 300.0, 1.0}));
  EXPECT_EQ(rows, 2u);
  EXPECT_EQ(f.Cell("InputName"), m.inputs);
  EXPECT_EQ(f.Text("OutputName"), "q.wrist_flexion");
  EXPECT_EQ(f.Text("OutputUnit"), "rad");
  EXPECT_EQ(f.Doubles("OutputOffset"), std::vector<double>{0.05});
}

TEST(MatFile, ATrialIsTimeAndOneVariablePerColumnWithNamesAndMetadata) {
  Trial t;
  t.time = {0.0, 0.5};
  t.AddColumn("u.ext", {0.0, 200.0});
  t.AddColumn("q.wrist_flexion", {0.1, NAN});
  t.metadata["seed"] = "3";
  const std::string path = Dir("mat_trial") + "/trial.mat";
  WriteTrialMat(t, path);
  MatFile f(path);
  ASSERT_NE(f.mat, nullptr);
  EXPECT_EQ(f.Doubles("time"), t.time);
  EXPECT_EQ(f.Doubles("u_ext"), (std::vector<double>{0.0, 200.0}));
  const std::vector<double> q = f.Doubles("q_wrist_flexion");
  ASSERT_EQ(q.size(), 2u);
  EXPECT_TRUE(std::isnan(q[1]));
  EXPECT_EQ(f.Cell("columns"),
            (std::vector<std::string>{"u.ext", "u_ext", "q.wrist_flexion", "q_wrist_flexion"}));
  EXPECT_EQ(f.Cell("metadata"), (std::vector<std::string>{"seed", "3"}));
  EXPECT_EQ(MatVariableName("f.ECR-L"), "f_ECR_L");
  EXPECT_EQ(MatVariableName("1x"), "v_1x");
}

TEST(MatFile, AnUnwritablePathIsNamedAndLeavesNoFile) {
  const std::string dir = Dir("mat_bad");
  Trial t;
  t.time = {0.0};
  EXPECT_THROW(
      {
        try {
          WriteTrialMat(t, dir + "/missing/trial.mat");
        } catch (const std::runtime_error& e) {
          EXPECT_NE(std::string(e.what()).find("missing/trial.mat"), std::string::npos);
          throw;
        }
      },
      std::runtime_error);
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

}  // namespace
}  // namespace fesim
