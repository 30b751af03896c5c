// Tests of the synthetic camera: projection of boxes, depth order, truncation, occlusion and the
// shapes of vehicle profiles.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "grid_vision_fusion/simulation/synthetic_camera.h"

namespace grid_vision_fusion
{
namespace
{
// A 640 x 240 camera with f = 400 px, principal point (320, 120), 1.65 m above the ground,
// looking along world +x. Optical frame: x right (= world −y), y down (= world −z), z forward.
SyntheticCameraModel camera()
{
  SyntheticCameraModel model;
  model.projection << 400.0, 0.0, 320.0, 0.0, 0.0, 400.0, 120.0, 0.0, 0.0, 0.0, 1.0, 0.0;
  model.width = 640;
  model.height = 240;
  return model;
}

Eigen::Isometry3d worldFromCamera()
{
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() << 0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0;
  pose.translation() << 0.0, 0.0, 1.65;
  return pose;
}

Actor car(double x, double y)
{
  Actor a;
  a.type = "Car";
  a.length = 4.0;
  a.width = 1.8;
  a.height = 1.5;
  a.trajectory = Trajectory::parked({x, y, 0.0});
  a.color_rgb = 0xC02020;
  return a;
}
}  // namespace

TEST(SyntheticCamera, ProjectsABoxWhereThePinholeSays)
{
  // Rear face of a car at 10 m: x = 8 m. Its bottom (z = 0, 1.65 m below the camera) lands at
  // v = 120 + 400·1.65/8 = 202.5; its roof (z = 1.5) at v = 120 + 400·0.15/8 = 127.5; its sides
  // (y = ±0.9) at u = 320 ∓ 400·0.9/8 = 275, 365 — for the rear face. The front face at 12 m is
  // smaller, so the box is the rear face's except for the roof line seen up to 12 m:
  // v = 120 + 400·0.15/12 = 125.
  const ActorInImage a = projectBox(car(10.0, 0.0).boxAt(0.0), worldFromCamera(), camera());
  ASSERT_TRUE(a.in_view);
  EXPECT_NEAR(a.box.x_min, 275.0, 1e-6);
  EXPECT_NEAR(a.box.x_max, 365.0, 1e-6);
  EXPECT_NEAR(a.box.y_min, 125.0, 1e-6);
  EXPECT_NEAR(a.box.y_max, 202.5, 1e-6);
  EXPECT_NEAR(a.truncation, 0.0, 1e-12);
  // Behind the camera: not in view.
  EXPECT_FALSE(projectBox(car(-10.0, 0.0).boxAt(0.0), worldFromCamera(), camera()).in_view);
}

TEST(SyntheticCamera, TruncationAtTheImageBorder)
{
  // A car 8 m ahead, 5 m to the right: x ∈ [6, 10], y ∈ [−5.9, −4.1]. Unclipped u from
  // 320 + 400·4.1/10 = 484 to 320 + 400·5.9/6 = 713.33, clipped at 639; v is not clipped
  // (230 at most). Truncation = 1 − 155 / 229.33 = 0.3241.
  const ActorInImage a = projectBox(car(8.0, -5.0).boxAt(0.0), worldFromCamera(), camera());
  ASSERT_TRUE(a.in_view);
  EXPECT_FLOAT_EQ(a.box.x_max, 639.F);
  EXPECT_NEAR(a.box.x_min, 484.0, 1e-4);
  EXPECT_NEAR(a.truncation, 1.0 - 155.0 / (713.0 + 1.0 / 3.0 - 484.0), 1e-6);
}

TEST(SyntheticCamera, DepthOrderAndOcclusion)
{
  // Car 0 at 10 m hides most of car 1 at 18 m, shifted 1 m to the left.
  const std::vector<Actor> actors{car(10.0, 0.0), car(18.0, 1.0)};
  const SceneSnapshot scene(actors, {}, 0.0);
  const RenderedImage image = renderCamera(scene, {0xC02020, 0x20C020}, {}, worldFromCamera(), camera());
  ASSERT_EQ(image.bgr.size(), cv::Size(640, 240));
  // The centre of the near car's rear face: u = 320, v = 160.
  EXPECT_EQ(image.object_id.at<int>(160, 320), 0);
  // Sky at the top, ground at the bottom.
  EXPECT_EQ(image.object_id.at<int>(2, 320), -1);
  const cv::Vec3b sky = image.bgr.at<cv::Vec3b>(2, 320);
  EXPECT_GT(sky[0], sky[2]) << "sky should be blue";
  EXPECT_EQ(image.actors[0].occlusionLevel(), 0);
  EXPECT_EQ(image.actors[0].visible_pixels, image.actors[0].silhouette_pixels);
  EXPECT_GT(image.actors[1].silhouette_pixels, image.actors[1].visible_pixels);
  EXPECT_GE(image.actors[1].occlusionLevel(), 1);
  EXPECT_GT(image.actors[1].visible_pixels, 0);
  // The near car is drawn in its colour (shaded), red dominant.
  const cv::Vec3b body = image.bgr.at<cv::Vec3b>(190, 320);
  EXPECT_GT(body[2], body[1]);
  if (const char* dump = std::getenv("GVF_DUMP_RENDER"))
  {
    cv::imwrite(dump, image.bgr);
  }
}

TEST(SyntheticCamera, SeesTheVehicleProfileTheLidarSees)
{
  // A car profile 10 m ahead, seen from behind on a cambered road: fewer pixels than its box
  // (the boot, the cabin narrower than the body, the rounded corners), windows drawn as glass;
  // its label box is the box's, and every pixel the camera gives the car is one where the
  // profile's ray cast hits the car.
  GroundSurface ground;
  ground.camber = 0.03;
  Actor profile = car(10.0, 0.0);
  profile.shape = VehicleShape::kCar;
  const SceneSnapshot boxes({car(10.0, 0.0)}, {}, 0.0, ground);
  const SceneSnapshot profiles({profile}, {}, 0.0, ground);
  const RenderedImage box_image = renderCamera(boxes, {0xC02020}, {}, worldFromCamera(), camera());
  const RenderedImage image = renderCamera(profiles, {0xC02020}, {}, worldFromCamera(), camera());
  const int box_pixels = box_image.actors[0].visible_pixels;
  const int pixels = image.actors[0].visible_pixels;
  EXPECT_LT(pixels, 0.9 * box_pixels);
  EXPECT_GT(pixels, 0.6 * box_pixels);
  EXPECT_EQ(image.actors[0].silhouette_pixels, pixels) << "nothing hides it";
  EXPECT_EQ(image.actors[0].box.x_min, box_image.actors[0].box.x_min);
  EXPECT_EQ(image.actors[0].box.y_max, box_image.actors[0].box.y_max);
  // The rear window (about 1.2 m high on the centre line: v = 120 + 400 · 0.45 / 8.7) is glass,
  // bluer than the body below it (v = 120 + 400 · 1.24 / 8) in the car's red.
  const cv::Vec3b window = image.bgr.at<cv::Vec3b>(142, 320);
  const cv::Vec3b body = image.bgr.at<cv::Vec3b>(182, 320);
  EXPECT_EQ(image.object_id.at<int>(142, 320), 0);
  EXPECT_GT(window[0], body[0]);
  EXPECT_GT(window[0] - window[2], body[0] - body[2]) << "bluer";
  // The box's top corners are sky or ground for the profile.
  EXPECT_EQ(box_image.object_id.at<int>(129, 278), 0);
  EXPECT_EQ(image.object_id.at<int>(129, 278), -1);
}

}  // namespace grid_vision_fusion
