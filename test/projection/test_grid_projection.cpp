// Unit tests of the grid projection: pinhole model, cell selection and state, ground points and
// columns, time alignment, dropping, and the real KITTI data (test/data, KITTI CC BY-NC-SA 3.0,
// see the READMEs there).
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "grid_vision_fusion/kitti/kitti_calibration.h"
#include "grid_vision_fusion/projection/grid_projection.h"

namespace grid_vision_fusion
{
namespace
{
const std::string kDataDir = GVF_TEST_DATA_DIR;
constexpr double kPixelTolerance = 0.5;

/// A small grid with arrays it owns; the view lends them to projectGrid().
struct TestGrid
{
  std::uint32_t width;
  std::uint32_t height;
  double resolution;
  double origin_x;
  double origin_y;
  std::vector<float> p_static, p_dynamic, vx, vy;

  TestGrid(std::uint32_t w, std::uint32_t h, double res, double ox, double oy)
      : width(w),
        height(h),
        resolution(res),
        origin_x(ox),
        origin_y(oy),
        p_static(w * h, 0.F),
        p_dynamic(w * h, 0.F),
        vx(w * h, 0.F),
        vy(w * h, 0.F)
  {
  }

  /// Sets the cell whose centre is (x, y).
  void set(double x, double y, float ps, float pd, float cell_vx = 0.F, float cell_vy = 0.F)
  {
    const auto col = static_cast<std::size_t>(std::floor((x - origin_x) / resolution));
    const auto row = static_cast<std::size_t>(std::floor((y - origin_y) / resolution));
    const std::size_t i = row * width + col;
    p_static.at(i) = ps;
    p_dynamic.at(i) = pd;
    vx.at(i) = cell_vx;
    vy.at(i) = cell_vy;
  }

  GridCellsView view() const
  {
    GridCellsView v;
    v.width = width;
    v.height = height;
    v.resolution = resolution;
    v.origin_x = origin_x;
    v.origin_y = origin_y;
    v.p_static = p_static.data();
    v.p_dynamic = p_dynamic.data();
    v.vx = vx.data();
    v.vy = vy.data();
    return v;
  }
};

/// A grid in the velodyne frame covering x ∈ [-20, 40), y ∈ [-30, 30) with 0.2 m cells: the
/// centre of a cell lies at odd multiples of 0.1 m, so (10.1, 0.1) etc. are cell centres.
TestGrid veloGrid()
{
  return TestGrid(300, 300, 0.2, -20.0, -30.0);
}

/// KITTI 2011_09_26 colour camera 2 with the grid in the velodyne frame.
struct KittiSetup
{
  KittiRawCalibration calib = KittiRawCalibration::readDirectory(kDataDir + "/kitti_raw_2011_09_26");
  PinholeCamera camera{calib.p_rect[2], calib.image_size[2][0], calib.image_size[2][1]};
  ProjectionGeometry geometry;

  KittiSetup()
  {
    geometry.camera_from_grid = calib.rectifiedFromVelo();
    geometry.ground_z = -1.73;  // the velodyne is mounted 1.73 m above the road
  }

  Eigen::Vector2d pixelOf(const Eigen::Vector3d& velo_point) const
  {
    Eigen::Vector2d pixel;
    double depth = 0.0;
    EXPECT_TRUE(camera.project(geometry.camera_from_grid * velo_point, pixel, depth));
    return pixel;
  }
};

TEST(PinholeCamera, KittiCheckValues)
{
  const KittiSetup kitti;
  Eigen::Vector2d pixel;
  double depth = 0.0;
  ASSERT_TRUE(kitti.camera.project(kitti.geometry.camera_from_grid * Eigen::Vector3d(10.0, 0.0, -1.73), pixel,
                                   depth));
  EXPECT_NEAR(pixel.x(), 615.3, kPixelTolerance);
  EXPECT_NEAR(pixel.y(), 303.5, kPixelTolerance);
  // The velodyne is 0.27 m behind camera 0 and camera 2 0.06 m ahead of it along the axis.
  EXPECT_NEAR(depth, 10.0 - 0.27 - 0.02, 0.05);
  ASSERT_TRUE(
      kitti.camera.project(kitti.geometry.camera_from_grid * Eigen::Vector3d(10.0, 0.0, 0.0), pixel, depth));
  EXPECT_NEAR(pixel.x(), 614.0, kPixelTolerance);
  EXPECT_NEAR(pixel.y(), 175.0, kPixelTolerance);
  EXPECT_FALSE(kitti.camera.project(Eigen::Vector3d(0.0, 0.0, -5.0), pixel, depth));
}

TEST(PinholeCamera, MatchesImageGeometryForRosCameraInfo)
{
  // ROS P: P(2,3) = 0, so u = (fx·x + Tx)/z + cx and v = (fy·y + Ty)/z + cy, as image_geometry.
  Eigen::Matrix<double, 3, 4> p;
  p << 500.0, 0.0, 320.0, -25.0, 0.0, 510.0, 240.0, 3.0, 0.0, 0.0, 1.0, 0.0;
  const PinholeCamera camera(p, 640, 480);
  Eigen::Vector2d pixel;
  double depth = 0.0;
  ASSERT_TRUE(camera.project(Eigen::Vector3d(1.0, -0.5, 4.0), pixel, depth));
  EXPECT_DOUBLE_EQ(pixel.x(), (500.0 * 1.0 - 25.0) / 4.0 + 320.0);
  EXPECT_DOUBLE_EQ(pixel.y(), (510.0 * -0.5 + 3.0) / 4.0 + 240.0);
  EXPECT_DOUBLE_EQ(depth, 4.0);
  EXPECT_TRUE(camera.inImage(0.0, 0.0));
  EXPECT_FALSE(camera.inImage(640.0, 10.0));
  EXPECT_FALSE(camera.inImage(10.0, -0.01));
}

TEST(PinholeCamera, RejectsUncalibratedOrMalformedP)
{
  const Eigen::Matrix<double, 3, 4> zero = Eigen::Matrix<double, 3, 4>::Zero();
  try
  {
    PinholeCamera camera(zero, 640, 480);
    FAIL() << "a zero P was accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("focal length"), std::string::npos) << e.what();
  }
  Eigen::Matrix<double, 3, 4> p;
  p << 500.0, 0.0, 320.0, 0.0, 0.0, 500.0, 240.0, 0.0, 0.0, 0.0, 1.0, 0.0;
  EXPECT_NO_THROW(PinholeCamera(p, 640, 480));
  EXPECT_THROW(PinholeCamera(p, 0, 480), std::invalid_argument);
  Eigen::Matrix<double, 3, 4> skewed = p;
  skewed(2, 0) = 0.1;
  EXPECT_THROW(PinholeCamera(skewed, 640, 480), std::invalid_argument);
  Eigen::Matrix<double, 3, 4> nan = p;
  nan(0, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(PinholeCamera(nan, 640, 480), std::invalid_argument);
}

TEST(GridProjection, GroundPointAndColumnLandOnTheKittiCheckValues)
{
  const KittiSetup kitti;
  TestGrid grid = TestGrid(5, 5, 0.2, 9.5, -0.5);  // cell (2, 2) has its centre at (10, 0)
  grid.set(10.0, 0.0, 0.9F, 0.05F);
  GridProjectionConfig config;
  ProjectedCells cells = projectGrid(grid.view(), kitti.camera, kitti.geometry, config);
  ASSERT_EQ(cells.size(), 1U);
  EXPECT_EQ(cells.cells_selected, 1U);
  EXPECT_NEAR(cells.u[0], 615.3, kPixelTolerance);
  EXPECT_NEAR(cells.v[0], 303.5, kPixelTolerance);
  EXPECT_NEAR(cells.depth[0], 9.71, 0.05);
  EXPECT_FLOAT_EQ(cells.x[0], 10.F);
  EXPECT_NEAR(cells.y[0], 0.F, 1e-6);
  EXPECT_FLOAT_EQ(cells.p_static[0], 0.9F);
  EXPECT_FLOAT_EQ(cells.p_dynamic[0], 0.05F);
  EXPECT_EQ(cells.state[0], static_cast<std::uint8_t>(CellState::kStatic));

  // Column mode, top at the velodyne height (z = 0): the second check value. Three points: the
  // middle one halfway (z = −0.865) lies between them in v.
  config.column_mode = true;
  config.column_height = 1.73;
  config.column_points = 3;
  cells = projectGrid(grid.view(), kitti.camera, kitti.geometry, config);
  ASSERT_EQ(cells.size(), 3U);
  EXPECT_NEAR(cells.u[0], 615.3, kPixelTolerance);
  EXPECT_NEAR(cells.v[0], 303.5, kPixelTolerance);
  const Eigen::Vector2d middle = kitti.pixelOf(Eigen::Vector3d(10.0, 0.0, -0.865));
  EXPECT_NEAR(cells.u[1], middle.x(), 1e-3);
  EXPECT_NEAR(cells.v[1], middle.y(), 1e-3);
  EXPECT_NEAR(cells.u[2], 614.0, kPixelTolerance);
  EXPECT_NEAR(cells.v[2], 175.0, kPixelTolerance);
  for (std::size_t i = 0; i < 3; ++i)
  {
    EXPECT_FLOAT_EQ(cells.x[i], 10.F);  // every column point carries its cell's centre
  }
}

TEST(GridProjection, CellsStandOnTheGroundTheGridCarries)
{
  const KittiSetup kitti;
  TestGrid grid = TestGrid(5, 5, 0.2, 9.5, -0.5);  // cell (2, 2) has its centre at (10, 0)
  grid.set(10.0, 0.0, 0.9F, 0.05F);
  grid.set(10.2, 0.2, 0.9F, 0.05F);  // cell (3, 3): no ground of its own
  std::vector<float> ground(grid.p_static.size(), std::numeric_limits<float>::quiet_NaN());
  ground[2 * 5 + 2] = -1.98F;  // the road 0.25 m lower than the plane at the sensor's height
  GridCellsView view = grid.view();
  view.ground_z = ground.data();
  const GridProjectionConfig config;
  const ProjectedCells cells = projectGrid(view, kitti.camera, kitti.geometry, config);
  ASSERT_EQ(cells.size(), 2U);
  const Eigen::Vector2d own = kitti.pixelOf(Eigen::Vector3d(10.0, 0.0, -1.98));
  EXPECT_NEAR(cells.u[0], own.x(), 1e-3);
  EXPECT_NEAR(cells.v[0], own.y(), 1e-3);
  EXPECT_GT(cells.v[0], 303.5 + 10.0) << "0.25 m lower at 10 m: about 18 px lower in the image";
  const Eigen::Vector2d plane = kitti.pixelOf(Eigen::Vector3d(10.2, 0.2, -1.73));
  EXPECT_NEAR(cells.v[1], plane.y(), 1e-3) << "a cell without a ground of its own takes the plane";

  GridProjectionConfig plane_only = config;
  plane_only.ground_from_grid = false;
  const ProjectedCells on_plane = projectGrid(view, kitti.camera, kitti.geometry, plane_only);
  ASSERT_EQ(on_plane.size(), 2U);
  EXPECT_NEAR(on_plane.u[0], 615.3, kPixelTolerance);
  EXPECT_NEAR(on_plane.v[0], 303.5, kPixelTolerance);
}

TEST(GridProjection, DropsCellsBehindTooNearOrOutsideTheImage)
{
  const KittiSetup kitti;
  TestGrid grid = veloGrid();
  grid.set(-10.1, 0.1, 0.9F, 0.F);  // behind the car
  grid.set(0.3, 0.1, 0.9F, 0.F);    // 0.03 m in front of camera 2: nearer than min_depth
  grid.set(10.1, 20.1, 0.9F, 0.F);  // 63° to the left: in front, but left of the image
  grid.set(20.1, 0.1, 0.9F, 0.F);   // straight ahead: kept
  const ProjectedCells cells = projectGrid(grid.view(), kitti.camera, kitti.geometry, GridProjectionConfig{});
  EXPECT_EQ(cells.cells_selected, 4U);
  EXPECT_EQ(cells.points_behind, 2U);
  EXPECT_EQ(cells.points_outside, 1U);
  ASSERT_EQ(cells.size(), 1U);
  EXPECT_NEAR(cells.x[0], 20.1, 1e-5);
  for (std::size_t i = 0; i < cells.size(); ++i)
  {
    EXPECT_GE(cells.depth[i], GridProjectionConfig{}.min_depth);
    EXPECT_TRUE(kitti.camera.inImage(cells.u[i], cells.v[i]));
  }
}

TEST(GridProjection, NearCellsProjectWhereTheirColumnCrossesTheBottomRow)
{
  const KittiSetup kitti;
  TestGrid grid = veloGrid();
  grid.set(4.1, 0.1, 0.9F, 0.F);  // 4 m ahead: the road there lies below the image
  grid.set(1.1, 0.1, 0.9F, 0.F);  // 1 m ahead: even 1 m above the road is below the image
  GridProjectionConfig config;
  config.column_height = 1.0;  // the 4 m column crosses the bottom row about 0.6 m up
  ProjectedCells cells = projectGrid(grid.view(), kitti.camera, kitti.geometry, config);
  EXPECT_EQ(cells.points_outside, 1U);
  ASSERT_EQ(cells.size(), 1U);
  EXPECT_FLOAT_EQ(cells.v[0], kitti.camera.height() - 0.5F);
  EXPECT_NEAR(cells.x[0], 4.1, 1e-5);
  // The pixel is the image of the column point at that row: find its height by bisection.
  double low = -1.73, high = -1.73 + config.column_height;
  for (int i = 0; i < 60; ++i)
  {
    const double mid = 0.5 * (low + high);
    (kitti.pixelOf(Eigen::Vector3d(4.1, 0.1, mid)).y() > cells.v[0] ? low : high) = mid;
  }
  Eigen::Vector2d pixel;
  double depth = 0.0;
  ASSERT_TRUE(
      kitti.camera.project(kitti.geometry.camera_from_grid * Eigen::Vector3d(4.1, 0.1, low), pixel, depth));
  EXPECT_NEAR(cells.u[0], pixel.x(), 1e-2);
  EXPECT_NEAR(cells.depth[0], depth, 1e-3);

  config.near_cells_at_bottom = false;  // the paper's ground points only: both dropped
  cells = projectGrid(grid.view(), kitti.camera, kitti.geometry, config);
  EXPECT_EQ(cells.size(), 0U);
  EXPECT_EQ(cells.points_outside, 2U);
}

TEST(GridProjection, TimeAlignmentMovesDynamicCellsWithTheirVelocity)
{
  const KittiSetup kitti;
  TestGrid grid = veloGrid();
  grid.set(10.1, 0.1, 0.05F, 0.9F, 10.F, 0.F);  // dynamic, 10 m/s along x
  grid.set(15.1, 2.1, 0.9F, 0.05F, 10.F, 0.F);  // static: its velocity is meaningless, it stays
  ProjectionGeometry geometry = kitti.geometry;
  geometry.time_offset = 0.05;  // the image was taken 50 ms after the scan
  GridProjectionConfig config;
  ProjectedCells cells = projectGrid(grid.view(), kitti.camera, geometry, config);
  ASSERT_EQ(cells.size(), 2U);
  // Row-major output, rows along +y: the dynamic cell (y = 0.1) first, the static (y = 2.1) second.
  const std::size_t dyn = 0;
  const std::size_t sta = 1;
  ASSERT_EQ(cells.state[dyn], static_cast<std::uint8_t>(CellState::kDynamic));
  ASSERT_EQ(cells.state[sta], static_cast<std::uint8_t>(CellState::kStatic));
  EXPECT_NEAR(cells.x[dyn], 10.1 + 0.5, 1e-5);  // 10 m/s × 50 ms = 0.5 m
  EXPECT_NEAR(cells.y[dyn], 0.1, 1e-5);
  const Eigen::Vector2d predicted = kitti.pixelOf(Eigen::Vector3d(10.6, 0.1, -1.73));
  EXPECT_NEAR(cells.u[dyn], predicted.x(), 1e-3);
  EXPECT_NEAR(cells.v[dyn], predicted.y(), 1e-3);
  EXPECT_FLOAT_EQ(cells.vx[dyn], 10.F);
  EXPECT_NEAR(cells.x[sta], 15.1, 1e-5);

  // Switched off: the dynamic cell stays where the scan saw it.
  config.predict_to_image_stamp = false;
  cells = projectGrid(grid.view(), kitti.camera, geometry, config);
  ASSERT_EQ(cells.size(), 2U);
  EXPECT_NEAR(cells.x[dyn], 10.1, 1e-5);
  const Eigen::Vector2d unmoved = kitti.pixelOf(Eigen::Vector3d(10.1, 0.1, -1.73));
  EXPECT_NEAR(cells.v[dyn], unmoved.y(), 1e-3);
  EXPECT_GT(cells.v[dyn] - predicted.y(), 2.0)
      << "the unmoved cell, 0.5 m nearer, must land visibly lower in the image";
}

TEST(GridProjection, SelectsCellsByThresholdAndDecidesTheirState)
{
  const KittiSetup kitti;
  TestGrid grid = veloGrid();
  grid.set(10.1, -4.1, 0.39F, 0.39F);  // neither passes 0.4: not projected
  grid.set(10.1, -2.1, 0.40F, 0.10F);  // static
  grid.set(10.1, 0.1, 0.30F, 0.50F);   // dynamic: P(D) > 0.5 (P(S) + P(D))
  grid.set(10.1, 2.1, 0.45F, 0.45F);   // tie: static
  grid.set(10.1, 4.1, 0.60F, 0.30F);   // static at ratio 0.5, dynamic at ratio 0.3
  GridProjectionConfig config;
  config.min_dynamic_speed = 0.0;  // the masses alone (these cells have no velocity)
  ProjectedCells cells = projectGrid(grid.view(), kitti.camera, kitti.geometry, config);
  ASSERT_EQ(cells.size(), 4U);
  EXPECT_EQ(cells.cells_selected, 4U);
  // Row-major: increasing y.
  const auto s = static_cast<std::uint8_t>(CellState::kStatic);
  const auto d = static_cast<std::uint8_t>(CellState::kDynamic);
  EXPECT_EQ(cells.state, (std::vector<std::uint8_t>{s, d, s, s}));
  EXPECT_NEAR(cells.y[0], -2.1, 1e-5);

  config.dynamic_ratio = 0.3;
  cells = projectGrid(grid.view(), kitti.camera, kitti.geometry, config);
  EXPECT_EQ(cells.state, (std::vector<std::uint8_t>{s, d, d, d}));

  config.occupied_threshold = 0.5;
  cells = projectGrid(grid.view(), kitti.camera, kitti.geometry, config);
  EXPECT_EQ(cells.size(), 2U);  // (0.3, 0.5) and (0.6, 0.3)
}

TEST(GridProjection, VelocityTestMakesSlowOrUncertainDynamicCellsStatic)
{
  // A stopped object keeps dynamic mass while its particles slow down: with min_dynamic_speed a
  // DYNAMIC cell (by its masses) needs a mean velocity of at least that speed, and with
  // mahalanobis_threshold a velocity that many variances away from zero.
  const KittiSetup kitti;
  TestGrid grid = veloGrid();
  grid.set(10.1, -2.1, 0.10F, 0.80F, 5.0F, 0.0F);  // fast
  grid.set(10.1, 0.1, 0.10F, 0.80F, 0.6F, 0.0F);   // slower than 1 m/s
  grid.set(10.1, 2.1, 0.60F, 0.30F, 5.0F, 0.0F);   // fast, but static by its masses
  std::vector<float> var_x(grid.vx.size(), 1.0F);
  std::vector<float> var_y(grid.vx.size(), 1.0F);
  GridCellsView view = grid.view();
  const auto s = static_cast<std::uint8_t>(CellState::kStatic);
  const auto d = static_cast<std::uint8_t>(CellState::kDynamic);
  GridProjectionConfig config;
  EXPECT_DOUBLE_EQ(config.min_dynamic_speed, 1.0);
  EXPECT_EQ(projectGrid(view, kitti.camera, kitti.geometry, config).state,
            (std::vector<std::uint8_t>{d, s, s}));
  config.min_dynamic_speed = 0.0;  // the paper's rule: the masses alone
  EXPECT_EQ(projectGrid(view, kitti.camera, kitti.geometry, config).state,
            (std::vector<std::uint8_t>{d, d, s}));
  // Mahalanobis: 5^2 / 1 = 25 passes 16, 5^2 / 4 does not; without variances it is skipped.
  config.mahalanobis_threshold = 16.0;
  EXPECT_EQ(projectGrid(view, kitti.camera, kitti.geometry, config).state,
            (std::vector<std::uint8_t>{d, d, s}));
  view.v_var_x = var_x.data();
  view.v_var_y = var_y.data();
  EXPECT_EQ(projectGrid(view, kitti.camera, kitti.geometry, config).state,
            (std::vector<std::uint8_t>{d, s, s}));
  std::fill(var_x.begin(), var_x.end(), 4.0F);
  EXPECT_EQ(projectGrid(view, kitti.camera, kitti.geometry, config).state,
            (std::vector<std::uint8_t>{s, s, s}));
  EXPECT_EQ(cellState(0.1F, 0.8F, 5.0F, 0.0F, -1.0F, -1.0F, config), CellState::kDynamic);
  EXPECT_EQ(cellState(0.1F, 0.8F, 5.0F, 0.0F, 4.0F, 4.0F, config), CellState::kStatic);
}

TEST(GridProjection, InvalidCellsAreCountedNotProjected)
{
  const KittiSetup kitti;
  TestGrid grid = veloGrid();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  grid.set(10.1, -2.1, nan, 0.F);
  grid.set(10.1, 0.1, 0.05F, 0.9F, nan, 1.F);  // dynamic without a velocity
  grid.set(10.1, 2.1, 0.9F, 0.05F, nan, nan);  // static: velocity not needed, reported 0
  const ProjectedCells cells = projectGrid(grid.view(), kitti.camera, kitti.geometry, GridProjectionConfig{});
  EXPECT_EQ(cells.cells_invalid, 2U);
  ASSERT_EQ(cells.size(), 1U);
  EXPECT_FLOAT_EQ(cells.vx[0], 0.F);
  EXPECT_FLOAT_EQ(cells.vy[0], 0.F);
}

TEST(GridProjection, RejectsBadInputsNamingThem)
{
  const KittiSetup kitti;
  TestGrid grid = veloGrid();
  GridCellsView view = grid.view();
  view.resolution = 0.0;
  EXPECT_THROW(projectGrid(view, kitti.camera, kitti.geometry, GridProjectionConfig{}),
               std::invalid_argument);
  view = grid.view();
  view.vy = nullptr;
  EXPECT_THROW(projectGrid(view, kitti.camera, kitti.geometry, GridProjectionConfig{}),
               std::invalid_argument);
  ProjectionGeometry geometry = kitti.geometry;
  geometry.ground_z = std::numeric_limits<double>::infinity();
  EXPECT_THROW(projectGrid(grid.view(), kitti.camera, geometry, GridProjectionConfig{}),
               std::invalid_argument);

  // An empty grid is valid and gives nothing.
  GridCellsView empty;
  empty.resolution = 0.2;
  EXPECT_EQ(projectGrid(empty, kitti.camera, kitti.geometry, GridProjectionConfig{}).size(), 0U);

  const auto expectField = [](GridProjectionConfig config, const std::string& field)
  {
    try
    {
      config.validate();
      FAIL() << field << " accepted";
    }
    catch (const std::invalid_argument& e)
    {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  GridProjectionConfig config;
  EXPECT_NO_THROW(config.validate());
  config.occupied_threshold = 0.0;
  expectField(config, "occupied_threshold");
  config = GridProjectionConfig{};
  config.dynamic_ratio = 1.0;
  expectField(config, "dynamic_ratio");
  config = GridProjectionConfig{};
  config.min_dynamic_speed = -1.0;
  expectField(config, "min_dynamic_speed");
  config = GridProjectionConfig{};
  config.mahalanobis_threshold = std::nan("");
  expectField(config, "mahalanobis_threshold");
  config = GridProjectionConfig{};
  config.min_depth = std::nan("");
  expectField(config, "min_depth");
  config = GridProjectionConfig{};
  config.column_height = -1.0;
  expectField(config, "column_height");
  config = GridProjectionConfig{};
  config.column_points = 1;
  expectField(config, "column_points");
}

TEST(GridProjection, ViewLendsTheArraysToTheFusion)
{
  const KittiSetup kitti;
  TestGrid grid = veloGrid();
  grid.set(10.1, 0.1, 0.05F, 0.9F, 3.F, -1.F);
  grid.set(12.1, 0.1, 0.9F, 0.05F);
  const ProjectedCells cells = projectGrid(grid.view(), kitti.camera, kitti.geometry, GridProjectionConfig{});
  const ProjectedPointsView view = cells.view();
  ASSERT_EQ(view.size, 2U);
  EXPECT_EQ(view.u, cells.u.data());
  EXPECT_EQ(view.state, cells.state.data());
  EXPECT_EQ(view.vx[0], 3.F);
  EXPECT_DOUBLE_EQ(view.resolution, grid.view().resolution);
  EXPECT_GT(view.resolution, 0.0);
}

// --- Real KITTI object-benchmark frames ---------------------------------------------------------

/// One label_2 line (KITTI object devkit readme): type, truncated, occluded, alpha, 2-D box
/// (left, top, right, bottom) [px], dimensions (h, w, l) [m], bottom centre (x, y, z) in the
/// rectified camera-0 frame [m], rotation ry around its y axis [rad].
struct KittiLabel
{
  std::string type;
  double box[4] = {0.0, 0.0, 0.0, 0.0};
  double h = 0.0;
  double w = 0.0;
  double l = 0.0;
  Eigen::Vector3d location = Eigen::Vector3d::Zero();
  double rotation_y = 0.0;
};

std::vector<KittiLabel> readLabels(const std::string& path)
{
  std::ifstream input(path);
  if (!input)
  {
    throw std::runtime_error("cannot open " + path);
  }
  std::vector<KittiLabel> labels;
  std::string line;
  while (std::getline(input, line))
  {
    std::istringstream fields(line);
    KittiLabel label;
    double truncated = 0.0, occluded = 0.0, alpha = 0.0;
    if (fields >> label.type >> truncated >> occluded >> alpha >> label.box[0] >> label.box[1] >>
        label.box[2] >> label.box[3] >> label.h >> label.w >> label.l >> label.location.x() >>
        label.location.y() >> label.location.z() >> label.rotation_y)
    {
      labels.push_back(label);
    }
  }
  return labels;
}

std::vector<Eigen::Vector3d> readVelodyne(const std::string& path)
{
  std::ifstream input(path, std::ios::binary);
  if (!input)
  {
    throw std::runtime_error("cannot open " + path);
  }
  std::vector<Eigen::Vector3d> points;
  float xyzr[4];
  while (input.read(reinterpret_cast<char*>(xyzr), sizeof(xyzr)))
  {
    points.emplace_back(xyzr[0], xyzr[1], xyzr[2]);
  }
  return points;
}

/// Whether `p` (rectified camera-0 frame) lies inside the 3-D box of `label`.
bool insideBox(const KittiLabel& label, const Eigen::Vector3d& p)
{
  // Object frame: x along its length, y down (0 at the bottom), z along its width; the box is
  // rotated by ry around the camera y axis.
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(label.rotation_y, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d local = rotation.transpose() * (p - label.location);
  return std::abs(local.x()) <= label.l / 2 && local.y() <= 0.0 && local.y() >= -label.h &&
         std::abs(local.z()) <= label.w / 2;
}

class KittiObjectFrame : public ::testing::TestWithParam<std::string>
{
};

TEST_P(KittiObjectFrame, LidarPointsOfEachBoxProjectIntoItsImageBox)
{
  const std::string dir = kDataDir + "/kitti_object_samples/";
  const std::string frame = GetParam();
  const KittiObjectCalibration calib = KittiObjectCalibration::read(dir + "calib/" + frame + ".txt");
  const cv::Mat image = cv::imread(dir + "image_2/" + frame + ".png", cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(image.empty());
  const PinholeCamera camera(calib.p[2], static_cast<std::uint32_t>(image.cols),
                             static_cast<std::uint32_t>(image.rows));
  const Eigen::Isometry3d rect_from_velo = calib.rectifiedFromVelo();
  const std::vector<Eigen::Vector3d> scan = readVelodyne(dir + "velodyne/" + frame + ".bin");
  ASSERT_GT(scan.size(), 100000U);

  int cars = 0;
  for (const KittiLabel& label : readLabels(dir + "label_2/" + frame + ".txt"))
  {
    if (label.type == "DontCare")
    {
      continue;
    }
    int points = 0;
    int inside = 0;
    for (const Eigen::Vector3d& velo : scan)
    {
      const Eigen::Vector3d rect = rect_from_velo * velo;
      if (!insideBox(label, rect))
      {
        continue;
      }
      ++points;
      Eigen::Vector2d pixel;
      double depth = 0.0;
      if (camera.project(rect, pixel, depth) && pixel.x() >= label.box[0] && pixel.x() <= label.box[2] &&
          pixel.y() >= label.box[1] && pixel.y() <= label.box[3])
      {
        ++inside;
      }
    }
    if (points < 5)
    {
      continue;  // too far or hidden for a meaningful fraction
    }
    cars += label.type == "Car" ? 1 : 0;
    EXPECT_GE(static_cast<double>(inside) / points, 0.9)
        << frame << " " << label.type << " at z = " << label.location.z() << " m: " << inside << " of "
        << points << " lidar points inside its 2-D box";
  }
  EXPECT_GE(cars, 1) << "frame " << frame << " has no car with lidar points";
}

INSTANTIATE_TEST_SUITE_P(KittiObjectSamples, KittiObjectFrame, ::testing::Values("000001", "000002"));

TEST(GridProjection, KittiCarCellsProjectIntoItsFusionBand)
{
  // Frame 000002: occupy the grid cells (velodyne frame) that hold lidar points of the labelled
  // car, project their ground points with projectGrid() on the car's own ground height, and
  // check they fall in the car's fusion band (bottom edge ± h/4, doc/nodelets/fusion.md).
  const std::string dir = kDataDir + "/kitti_object_samples/";
  const KittiObjectCalibration calib = KittiObjectCalibration::read(dir + "calib/000002.txt");
  const Eigen::Isometry3d rect_from_velo = calib.rectifiedFromVelo();
  const std::vector<Eigen::Vector3d> scan = readVelodyne(dir + "velodyne/000002.bin");
  KittiLabel car;
  bool found = false;
  for (const KittiLabel& label : readLabels(dir + "label_2/000002.txt"))
  {
    if (label.type == "Car")
    {
      car = label;
      found = true;
    }
  }
  ASSERT_TRUE(found);
  TestGrid grid = TestGrid(300, 300, 0.2, 0.0, -30.0);  // x ∈ [0, 60), y ∈ [-30, 30)
  int points = 0;
  for (const Eigen::Vector3d& velo : scan)
  {
    if (insideBox(car, rect_from_velo * velo))
    {
      const double cx = grid.origin_x + (std::floor((velo.x() - grid.origin_x) / 0.2) + 0.5) * 0.2;
      const double cy = grid.origin_y + (std::floor((velo.y() - grid.origin_y) / 0.2) + 0.5) * 0.2;
      grid.set(cx, cy, 0.9F, 0.05F);
      ++points;
    }
  }
  ASSERT_GT(points, 20);

  ProjectionGeometry geometry;
  geometry.camera_from_grid = rect_from_velo;
  geometry.ground_z = (rect_from_velo.inverse() * car.location).z();  // the car's bottom, velodyne frame
  const ProjectedCells cells =
      projectGrid(grid.view(), PinholeCamera(calib.p[2], 1242, 375), geometry, GridProjectionConfig{});
  ASSERT_GT(cells.size(), 5U);
  const double box_height = car.box[3] - car.box[1];
  std::size_t in_band = 0;
  for (std::size_t i = 0; i < cells.size(); ++i)
  {
    if (cells.u[i] > car.box[0] && cells.u[i] < car.box[2] && cells.v[i] > car.box[3] - box_height / 4 &&
        cells.v[i] < car.box[3] + box_height / 4)
    {
      ++in_band;
    }
  }
  EXPECT_GE(static_cast<double>(in_band) / cells.size(), 0.9) << in_band << " of " << cells.size();
}

}  // namespace
}  // namespace grid_vision_fusion
