// Eigen matrices and vectors as parameters (ln/parameters_eigen.h) between
// clients of one in-process manager: shapes as LN 2.9 reports them, values
// in the program's storage order, overrides, callbacks, copies.
#include <gtest/gtest.h>

#include <optional>

#include "client/client_test_support.hpp"
#include "ln/parameters_eigen.h"

namespace ln::clienttest {
namespace {

using ln::parameters::parameter_block;
using ln::parameters::port_description;
using Rows = std::vector<std::vector<double>>;

class EigenParameters : public ::testing::Test {
 protected:
  InProcessManager manager;
  ScopedEnv no_prefix{"LN_PARAMETER_PREFIX", std::nullopt};
  std::unique_ptr<ln::client> provider = std::make_unique<ln::client>("prov", manager.address());
  std::unique_ptr<ln::client> caller = std::make_unique<ln::client>("caller", manager.address());
};

TEST_F(EigenParameters, MatricesAndVectorsKeepTheirShapeAndStorageOrder) {
  Eigen::Matrix<double, 2, 3> column_major, column_major_out;
  column_major << 1, 2, 3, 4, 5, 6;
  Eigen::Matrix<int32_t, 2, 3, Eigen::RowMajor> row_major, row_major_out;
  row_major << 1, 2, 3, 4, 5, 6;
  Eigen::Vector4f vector(0.5f, 1.5f, 2.5f, 3.5f), vector_out;
  Eigen::MatrixXd dynamic = Eigen::MatrixXd::Constant(3, 2, 7.0), dynamic_out(3, 2);
  parameter_block block(provider.get(), "eig");
  ASSERT_TRUE(block.register_parameters(
      port_description<Eigen::Matrix<double, 2, 3>>("cm", "column-major", &column_major, &column_major_out),
      port_description<Eigen::Matrix<int32_t, 2, 3, Eigen::RowMajor>>("rm", "", &row_major, &row_major_out),
      port_description<Eigen::Vector4f>("vec", "", &vector, &vector_out),
      port_description<Eigen::MatrixXd>("dyn", "", &dynamic, &dynamic_out)))
      << block.error_message();
  block.update();
  EXPECT_EQ(column_major_out, column_major);
  EXPECT_EQ(row_major_out, row_major);
  EXPECT_EQ(vector_out, vector);
  EXPECT_EQ(dynamic_out, dynamic);

  auto params = caller->get_parameters("eig");
  EXPECT_EQ(params.get_input<Rows>("cm"), (Rows{{1, 2, 3}, {4, 5, 6}}));
  EXPECT_EQ(params.get_input<Rows>("rm"), (Rows{{1, 2, 3}, {4, 5, 6}}));
  EXPECT_EQ(params.get_internal_value("vec").shape, (std::vector<std::size_t>{4})) << "a column vector is a list";
  EXPECT_EQ(params.get_input<std::vector<float>>("vec"), (std::vector<float>{0.5f, 1.5f, 2.5f, 3.5f}));
  EXPECT_EQ(params.get_internal_value("dyn").shape, (std::vector<std::size_t>{3, 2}));
  EXPECT_EQ(params.get_description("cm"), "column-major");

  params.set_override("cm", Rows{{10, 20, 30}, {40, 50, 60}}, false);
  params.set_override("rm", Rows{{-1, -2, -3}, {-4, -5, -6}}, false);
  params.set_override("vec", std::vector<float>{9, 8, 7, 6}, false);
  params.set_override("dyn", Rows{{1, 2}, {3, 4}, {5, 6}}, false);
  block.update();
  EXPECT_EQ(column_major_out(1, 0), 40);
  EXPECT_EQ(column_major_out(0, 2), 30);
  EXPECT_EQ(row_major_out(1, 2), -6);
  EXPECT_EQ(row_major_out(0, 1), -2);
  EXPECT_EQ(vector_out(3), 6);
  EXPECT_EQ(dynamic_out(2, 0), 5);
  EXPECT_EQ(dynamic_out(0, 1), 2);
  EXPECT_EQ(column_major(1, 0), 4) << "the program's input stays its own";
}

TEST_F(EigenParameters, CallbacksSeeTheNewValueAsTheirTypeAndMayChangeOrRefuseIt) {
  Eigen::Vector3d limits(1, 2, 3), limits_out;
  std::optional<Eigen::Vector3d> applied;
  port_description<Eigen::Vector3d> described(
      "limits", "", &limits, &limits_out,
      [](Eigen::Vector3d& v) {
        if (v.minCoeff() < 0) return false;
        v = v.cwiseMin(100.0);  // clamped, as a check may do
        return true;
      },
      [&](Eigen::Vector3d& v) { applied = v; });
  // A copy owns its shape: the original going first leaves it intact.
  std::optional<port_description<Eigen::Vector3d>> original(described);
  port_description<Eigen::Vector3d> copy = *original;
  original.reset();
  parameter_block block(provider.get(), "cb");
  ASSERT_TRUE(block.register_parameters(copy)) << block.error_message();
  auto params = caller->get_parameters("cb");
  params.set_override("limits", std::vector<double>{5, 500, 50}, false);
  block.update();
  EXPECT_EQ(limits_out, Eigen::Vector3d(5, 100, 50));
  ASSERT_TRUE(applied.has_value());
  EXPECT_EQ(*applied, Eigen::Vector3d(5, 100, 50));
  EXPECT_THROW(params.set_override("limits", std::vector<double>{-1, 0, 0}, false), std::runtime_error);
  block.update();
  EXPECT_EQ(limits_out, Eigen::Vector3d(5, 100, 50)) << "a refused value changes nothing";
}

}  // namespace
}  // namespace ln::clienttest
