#include "grid_vision_fusion/simulation/synthetic_world.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "grid_vision_fusion/projection/box_projection.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kDegToRad = M_PI / 180.0;
constexpr double kStandingEps = 1e-9;

struct Sphere
{
  Eigen::Vector3d centre;
  double radius;
};

Sphere boundingSphere(const GroundBox& box)
{
  return {Eigen::Vector3d(box.pose.x, box.pose.y, box.base_z + box.height / 2.0),
          0.5 * std::sqrt(box.length * box.length + box.width * box.width + box.height * box.height)};
}

/// Whether the ray may hit the sphere within (min_range, max_range].
bool mayHit(const Eigen::Vector3d& centre, double radius, const Eigen::Vector3d& origin,
            const Eigen::Vector3d& direction, double min_range, double max_range)
{
  const Eigen::Vector3d oc = centre - origin;
  const double along = oc.dot(direction);
  if (along + radius < min_range || along - radius > max_range)
  {
    return false;
  }
  return oc.squaredNorm() - along * along <= radius * radius;
}

// --- Vehicle profiles --------------------------------------------------------------------------

using Face = VehicleBody::Face;
using Part = VehicleBody::Part;
constexpr double kGolden = 0.6180339887498949;  // spreads one glass draw over the actors of a ray

/// The face through (a_along, a_z) and (b_along, b_z) of the plane spanned by `axis` (x or y) and
/// z, its normal on the side of `outward`.
Face faceThrough(int axis, double a_along, double a_z, double b_along, double b_z,
                 const Eigen::Vector3d& outward, bool glass = false)
{
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  normal[axis] = -(b_z - a_z);
  normal.z() = b_along - a_along;
  if (normal.dot(outward) < 0.0)
  {
    normal = -normal;
  }
  normal.normalize();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  point[axis] = a_along;
  point.z() = a_z;
  Face face;
  face.normal = normal;
  face.offset = normal.dot(point);
  face.glass = glass;
  return face;
}

/// The horizontal faces of a part from z0 to z1 [m].
void addFloorAndTop(Part& part, double z0, double z1)
{
  part.push_back({-Eigen::Vector3d::UnitZ(), -z0});
  part.push_back({Eigen::Vector3d::UnitZ(), z1});
}

/// Sides at |y| = half_bottom at z0 leaning in to |y| = half_top at z1.
void addSides(Part& part, double half_bottom, double half_top, double z0, double z1, bool glass,
              double glass_from_x = -1e9)
{
  for (double side : {1.0, -1.0})
  {
    Face face =
        faceThrough(1, side * half_bottom, z0, side * half_top, z1, Eigen::Vector3d(0.0, side, 0.0), glass);
    face.glass_from_x = glass_from_x;
    part.push_back(face);
  }
}

/// Vertical faces tangent to quarter arcs of `radius` [m] in the two corners at x = end (sign
/// +1: the front, −1: the rear) of a body of half width `half` [m]: the arc approximated by its
/// tangents at 30° and 60° between the end face and the sides.
void addRoundedCorners(Part& part, double end, double sign, double half, double radius)
{
  if (radius <= 0.0)
  {
    return;
  }
  for (double side : {1.0, -1.0})
  {
    const Eigen::Vector3d centre(end - sign * radius, side * (half - radius), 0.0);
    for (double angle : {M_PI / 6.0, M_PI / 3.0})
    {
      const Eigen::Vector3d normal(sign * std::cos(angle), side * std::sin(angle), 0.0);
      part.push_back({normal, normal.dot(centre) + radius});
    }
  }
}

/// A car: the lower body to the belt line at 0.6 h, its bonnet falling from the windscreen's base
/// to 0.46 h at the front and its boot to 0.52 h at the rear, plan corners rounded (0.22 w front,
/// 0.18 w rear); the cabin above it 0.1 w narrower at the belt and 0.3 w at the roof, from the
/// rear window's base 0.1 l ahead of the rear to the windscreen's base 0.27 l behind the front,
/// the windscreen and the rear window raked over 0.18 l and 0.14 l.
void carProfile(double l, double w, double h, Part& lower, Part& upper)
{
  const double front = l / 2.0, rear = -l / 2.0, belt = 0.6 * h;
  const double screen_base = front - 0.27 * l, screen_top = screen_base - 0.18 * l;
  const double rear_base = rear + 0.10 * l, rear_top = rear_base + 0.14 * l;
  addFloorAndTop(lower, 0.0, belt);
  lower.push_back({Eigen::Vector3d::UnitX(), front});
  lower.push_back({-Eigen::Vector3d::UnitX(), -rear});
  addSides(lower, w / 2.0, w / 2.0, 0.0, belt, false);
  lower.push_back(faceThrough(0, front, 0.46 * h, screen_base, belt, Eigen::Vector3d(1.0, 0.0, 1.0)));
  lower.push_back(faceThrough(0, rear, 0.52 * h, rear_base, belt, Eigen::Vector3d(-1.0, 0.0, 1.0)));
  addRoundedCorners(lower, front, 1.0, w / 2.0, 0.22 * w);
  addRoundedCorners(lower, rear, -1.0, w / 2.0, 0.18 * w);

  addFloorAndTop(upper, belt, h);
  upper.push_back(faceThrough(0, screen_base, belt, screen_top, h, Eigen::Vector3d::UnitX(), true));
  upper.push_back(faceThrough(0, rear_base, belt, rear_top, h, -Eigen::Vector3d::UnitX(), true));
  addSides(upper, 0.45 * w, 0.35 * w, belt, h, true);
}

/// A van: the lower body to the bonnet line at 0.45 h, the bonnet falling to 0.38 h at the front
/// from the windscreen's base 0.16 l behind it, plan corners rounded (0.2 w front, 0.05 w rear);
/// the upper body from there to the rear at full height, 0.04 w narrower at the bonnet line and
/// 0.12 w at the roof, the windscreen raked over 0.14 l, side windows in the cab (the 0.16 l behind
/// the windscreen's top).
void vanProfile(double l, double w, double h, Part& lower, Part& upper)
{
  const double front = l / 2.0, rear = -l / 2.0, belt = 0.45 * h;
  const double screen_base = front - 0.16 * l, screen_top = screen_base - 0.14 * l;
  addFloorAndTop(lower, 0.0, belt);
  lower.push_back({Eigen::Vector3d::UnitX(), front});
  lower.push_back({-Eigen::Vector3d::UnitX(), -rear});
  addSides(lower, w / 2.0, w / 2.0, 0.0, belt, false);
  lower.push_back(faceThrough(0, front, 0.38 * h, screen_base, belt, Eigen::Vector3d(1.0, 0.0, 1.0)));
  addRoundedCorners(lower, front, 1.0, w / 2.0, 0.2 * w);
  addRoundedCorners(lower, rear, -1.0, w / 2.0, 0.05 * w);

  addFloorAndTop(upper, belt, h);
  upper.push_back(faceThrough(0, screen_base, belt, screen_top, h, Eigen::Vector3d::UnitX(), true));
  upper.push_back({-Eigen::Vector3d::UnitX(), -rear});
  addSides(upper, 0.48 * w, 0.44 * w, belt, h, true, screen_top - 0.16 * l);
}

/// Where a ray (box frame) is inside a convex part: it enters through face `in` at t_in and
/// leaves through face `out` at t_out.
struct Crossing
{
  double t_in = -std::numeric_limits<double>::infinity();
  double t_out = std::numeric_limits<double>::infinity();
  int in = -1;
  int out = -1;
  bool hit() const { return in >= 0 && out >= 0 && t_in <= t_out; }
};

Crossing clip(const Part& part, const Eigen::Vector3d& o, const Eigen::Vector3d& d)
{
  Crossing c;
  for (std::size_t k = 0; k < part.size(); ++k)
  {
    const double along = part[k].normal.dot(d);
    const double gap = part[k].offset - part[k].normal.dot(o);  // >= 0 on the inner side
    if (std::abs(along) < 1e-12)
    {
      if (gap < 0.0)
      {
        return {};
      }
      continue;
    }
    const double t = gap / along;
    if (along < 0.0 && t > c.t_in)
    {
      c.t_in = t;
      c.in = static_cast<int>(k);
    }
    else if (along > 0.0 && t < c.t_out)
    {
      c.t_out = t;
      c.out = static_cast<int>(k);
    }
  }
  return c;
}

bool isGlass(const Face& face, const Eigen::Vector3d& point)
{
  return face.glass && point.x() >= face.glass_from_x;
}

/// The surface that stops a ray crossing the part `c` (box frame): its entry face, or where a
/// window lets the beam through (draw < transmission), the face it leaves through, unless that is
/// a window too and lets it through again. A range of infinity: it passed.
RayHit firstStop(const Part& part, const Crossing& c, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                 double draw, double transmission)
{
  RayHit hit;
  const Face& in = part[static_cast<std::size_t>(c.in)];
  hit.glass = isGlass(in, o + c.t_in * d);
  if (!hit.glass || !(draw < transmission))
  {
    hit.range = c.t_in;
    hit.normal = in.normal;
    return hit;
  }
  const double inside = draw / transmission;  // uniform in [0, 1) again, given that it passed
  const Face& out = part[static_cast<std::size_t>(c.out)];
  hit.glass = isGlass(out, o + c.t_out * d);
  if (hit.glass && inside < transmission)
  {
    return RayHit{};
  }
  hit.range = c.t_out;
  hit.normal = -out.normal;  // the far window or the interior, seen from inside
  return hit;
}

/// A world ray in the frame of `box` (x forward from its centre, y left, z up from its bottom).
void toBoxFrame(const GroundBox& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                Eigen::Vector3d& o, Eigen::Vector3d& d)
{
  const double c = std::cos(box.pose.yaw);
  const double s = std::sin(box.pose.yaw);
  const Eigen::Vector3d rel = origin - Eigen::Vector3d(box.pose.x, box.pose.y, box.base_z);
  o = Eigen::Vector3d(c * rel.x() + s * rel.y(), -s * rel.x() + c * rel.y(), rel.z());
  d = Eigen::Vector3d(c * direction.x() + s * direction.y(), -s * direction.x() + c * direction.y(),
                      direction.z());
}

// --- Ground ------------------------------------------------------------------------------------

/// One plane strip of a profiled ground: z = plane(x) + c0 + c1 · (y − center_y) for
/// lo <= y − center_y <= hi.
struct GroundStrip
{
  double lo, hi, c0, c1;
};

/// Nearest hit of the ray with one strip (from above) within (min_range, best.range].
void castStrip(const GroundSurface& g, const GroundStrip& strip, const Eigen::Vector3d& o,
               const Eigen::Vector3d& d, double min_range, RayHit& best)
{
  const double denominator = d.z() - g.slope_x * d.x() - strip.c1 * d.y();
  if (!(denominator < -1e-12))
  {
    return;
  }
  const double t =
      (g.height + g.slope_x * o.x() + strip.c0 + strip.c1 * (o.y() - g.center_y) - o.z()) / denominator;
  const double lateral = o.y() + t * d.y() - g.center_y;
  if (t > min_range && t <= best.range && lateral >= strip.lo - 1e-9 && lateral <= strip.hi + 1e-9)
  {
    best.range = t;
    best.object = RayHit::kGround;
    best.normal = Eigen::Vector3d(-g.slope_x, -strip.c1, 1.0).normalized();
  }
}

/// Nearest hit of the ray with the kerb's face at y − center_y = side · half_width (seen from
/// the road) within (min_range, best.range].
void castKerb(const GroundSurface& g, double side, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
              double min_range, RayHit& best)
{
  if (g.kerb_height <= 0.0 || !(side * d.y() > 1e-12))
  {
    return;
  }
  const double t = (g.center_y + side * g.half_width - o.y()) / d.y();
  const Eigen::Vector3d p = o + t * d;
  const double edge = g.z(p.x()) - g.camber * g.half_width;
  if (t > min_range && t <= best.range && p.z() >= edge && p.z() <= edge + g.kerb_height)
  {
    best.range = t;
    best.object = RayHit::kGround;
    best.normal = Eigen::Vector3d(0.0, -side, 0.0);
  }
}
}  // namespace

const char* vehicleShapeName(VehicleShape shape)
{
  switch (shape)
  {
    case VehicleShape::kCar:
      return "car";
    case VehicleShape::kVan:
      return "van";
    case VehicleShape::kBox:
      break;
  }
  return "box";
}

Trajectory Trajectory::waypoints(const std::vector<Eigen::Vector3d>& t_x_y, double initial_yaw)
{
  if (t_x_y.empty())
  {
    throw std::invalid_argument("a waypoint trajectory needs at least one waypoint");
  }
  for (std::size_t i = 1; i < t_x_y.size(); ++i)
  {
    if (!(t_x_y[i].x() > t_x_y[i - 1].x()))
    {
      throw std::invalid_argument("waypoint times must increase strictly (waypoint " + std::to_string(i) +
                                  ")");
    }
  }
  Trajectory trajectory;
  trajectory.kind_ = Kind::kWaypoints;
  trajectory.waypoints_ = t_x_y;
  // Yaw of every segment: its direction when it moves, else the yaw of the last moving segment
  // before it (or, for leading standing segments, of the first moving one).
  const std::size_t segments = t_x_y.size() > 1 ? t_x_y.size() - 1 : 0;
  std::vector<double> yaw(segments, std::nan(""));
  for (std::size_t i = 0; i < segments; ++i)
  {
    const Eigen::Vector2d step = t_x_y[i + 1].tail<2>() - t_x_y[i].tail<2>();
    if (step.norm() > kStandingEps)
    {
      yaw[i] = std::atan2(step.y(), step.x());
    }
  }
  double held = initial_yaw;
  for (double y : yaw)
  {
    if (!std::isnan(y))
    {
      held = y;
      break;
    }
  }
  for (double& y : yaw)
  {
    if (std::isnan(y))
    {
      y = held;
    }
    held = y;
  }
  trajectory.segment_yaw_ = yaw;
  trajectory.start_.yaw = yaw.empty() ? initial_yaw : yaw.front();
  return trajectory;
}

Trajectory Trajectory::constantTurn(const Pose2D& start, double speed, double yaw_rate)
{
  Trajectory trajectory;
  trajectory.kind_ = Kind::kConstantTurn;
  trajectory.start_ = start;
  trajectory.speed_ = speed;
  trajectory.yaw_rate_ = yaw_rate;
  return trajectory;
}

Trajectory Trajectory::posed(const std::vector<double>& times, const std::vector<Pose2D>& poses)
{
  if (times.size() != poses.size())
  {
    throw std::invalid_argument("posed trajectory: " + std::to_string(times.size()) + " times for " +
                                std::to_string(poses.size()) + " poses");
  }
  std::vector<Eigen::Vector3d> t_x_y;
  for (std::size_t i = 0; i < poses.size(); ++i)
  {
    t_x_y.emplace_back(times[i], poses[i].x, poses[i].y);
  }
  Trajectory trajectory = waypoints(t_x_y, poses.empty() ? 0.0 : poses.front().yaw);
  for (const Pose2D& pose : poses)
  {
    trajectory.waypoint_yaw_.push_back(pose.yaw);
  }
  trajectory.start_.yaw = poses.front().yaw;
  return trajectory;
}

Trajectory Trajectory::parked(const Pose2D& pose)
{
  return waypoints({Eigen::Vector3d(0.0, pose.x, pose.y)}, pose.yaw);
}

Pose2D Trajectory::poseAt(double t) const
{
  if (kind_ == Kind::kConstantTurn)
  {
    Pose2D pose;
    pose.yaw = start_.yaw + yaw_rate_ * t;
    if (std::abs(yaw_rate_) < 1e-12)
    {
      pose.x = start_.x + speed_ * t * std::cos(start_.yaw);
      pose.y = start_.y + speed_ * t * std::sin(start_.yaw);
    }
    else
    {
      const double r = speed_ / yaw_rate_;
      pose.x = start_.x + r * (std::sin(pose.yaw) - std::sin(start_.yaw));
      pose.y = start_.y - r * (std::cos(pose.yaw) - std::cos(start_.yaw));
    }
    return pose;
  }
  const auto& w = waypoints_;
  if (t <= w.front().x() || w.size() == 1)
  {
    return {w.front().y(), w.front().z(), start_.yaw};
  }
  if (t >= w.back().x())
  {
    return {w.back().y(), w.back().z(), waypoint_yaw_.empty() ? segment_yaw_.back() : waypoint_yaw_.back()};
  }
  const auto next = std::upper_bound(w.begin(), w.end(), t,
                                     [](double time, const Eigen::Vector3d& p) { return time < p.x(); });
  const std::size_t i = static_cast<std::size_t>(next - w.begin()) - 1;
  const double s = (t - w[i].x()) / (w[i + 1].x() - w[i].x());
  const Eigen::Vector2d p = (1.0 - s) * w[i].tail<2>() + s * w[i + 1].tail<2>();
  if (waypoint_yaw_.empty())
  {
    return {p.x(), p.y(), segment_yaw_[i]};
  }
  const double turn = std::remainder(waypoint_yaw_[i + 1] - waypoint_yaw_[i], 2.0 * M_PI);
  return {p.x(), p.y(), std::remainder(waypoint_yaw_[i] + s * turn, 2.0 * M_PI)};
}

Eigen::Vector2d Trajectory::velocityAt(double t) const
{
  if (kind_ == Kind::kConstantTurn)
  {
    const double yaw = start_.yaw + yaw_rate_ * t;
    return speed_ * Eigen::Vector2d(std::cos(yaw), std::sin(yaw));
  }
  const auto& w = waypoints_;
  if (w.size() == 1 || t < w.front().x() || t >= w.back().x())
  {
    return Eigen::Vector2d::Zero();
  }
  const auto next = std::upper_bound(w.begin(), w.end(), t,
                                     [](double time, const Eigen::Vector3d& p) { return time < p.x(); });
  const std::size_t i = static_cast<std::size_t>(next - w.begin()) - 1;
  return (w[i + 1].tail<2>() - w[i].tail<2>()) / (w[i + 1].x() - w[i].x());
}

std::vector<Eigen::Vector3d> GroundBox::corners() const
{
  const auto corners =
      orientedBoxCorners(Eigen::Vector3d(pose.x, pose.y, base_z), pose.yaw, length, width, height);
  return {corners.begin(), corners.end()};
}

GroundBox Actor::boxAt(double t) const
{
  GroundBox box;
  box.pose = trajectory.poseAt(t);
  box.length = length;
  box.width = width;
  box.height = height;
  box.shape = shape;
  box.glass_transmission = glass_transmission;
  return box;
}

RayHit intersectBox(const GroundBox& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                    double min_range)
{
  const double c = std::cos(box.pose.yaw);
  const double s = std::sin(box.pose.yaw);
  const Eigen::Vector3d rel = origin - Eigen::Vector3d(box.pose.x, box.pose.y, box.base_z);
  // Into the box frame: rotate by −yaw.
  const Eigen::Vector3d o(c * rel.x() + s * rel.y(), -s * rel.x() + c * rel.y(), rel.z());
  const Eigen::Vector3d d(c * direction.x() + s * direction.y(), -s * direction.x() + c * direction.y(),
                          direction.z());
  const double lo[3] = {-box.length / 2.0, -box.width / 2.0, 0.0};
  const double hi[3] = {box.length / 2.0, box.width / 2.0, box.height};
  double t_enter = -std::numeric_limits<double>::infinity();
  double t_exit = std::numeric_limits<double>::infinity();
  int enter_axis = -1;
  double enter_sign = 0.0;
  for (int axis = 0; axis < 3; ++axis)
  {
    if (std::abs(d[axis]) < 1e-12)
    {
      if (o[axis] < lo[axis] || o[axis] > hi[axis])
      {
        return {};
      }
      continue;
    }
    double t0 = (lo[axis] - o[axis]) / d[axis];
    double t1 = (hi[axis] - o[axis]) / d[axis];
    double sign = -1.0;  // entering through the low face: its normal points to −axis
    if (t0 > t1)
    {
      std::swap(t0, t1);
      sign = 1.0;
    }
    if (t0 > t_enter)
    {
      t_enter = t0;
      enter_axis = axis;
      enter_sign = sign;
    }
    t_exit = std::min(t_exit, t1);
  }
  if (t_enter > t_exit || t_enter <= min_range || enter_axis < 0)
  {
    return {};
  }
  RayHit hit;
  hit.range = t_enter;
  hit.object = 0;
  Eigen::Vector3d local_normal = Eigen::Vector3d::Zero();
  local_normal[enter_axis] = enter_sign;
  hit.normal = Eigen::Vector3d(c * local_normal.x() - s * local_normal.y(),
                               s * local_normal.x() + c * local_normal.y(), local_normal.z());
  return hit;
}

VehicleBody::VehicleBody(VehicleShape shape, double length, double width, double height)
{
  if (shape == VehicleShape::kCar)
  {
    carProfile(length, width, height, lower_, upper_);
  }
  else if (shape == VehicleShape::kVan)
  {
    vanProfile(length, width, height, lower_, upper_);
  }
  else
  {
    throw std::invalid_argument("VehicleBody: a box has no profile (use intersectBox)");
  }
}

RayHit VehicleBody::intersect(const GroundBox& box, const Eigen::Vector3d& origin,
                              const Eigen::Vector3d& direction, double min_range, double glass_draw,
                              double transmission) const
{
  Eigen::Vector3d o, d;
  toBoxFrame(box, origin, direction, o, d);
  RayHit best;
  const Crossing lower = clip(lower_, o, d);
  if (lower.hit() && lower.t_in > min_range)
  {
    best.range = lower.t_in;
    best.normal = lower_[static_cast<std::size_t>(lower.in)].normal;
  }
  const Crossing upper = clip(upper_, o, d);
  if (upper.hit() && upper.t_in > min_range && upper.t_in < best.range)
  {
    const RayHit stop = firstStop(upper_, upper, o, d, glass_draw, transmission);
    if (stop.range < best.range)
    {
      best = stop;
    }
  }
  if (!std::isfinite(best.range))
  {
    return {};
  }
  best.object = 0;
  const double c = std::cos(box.pose.yaw);
  const double s = std::sin(box.pose.yaw);
  const Eigen::Vector3d n = best.normal;
  best.normal = Eigen::Vector3d(c * n.x() - s * n.y(), s * n.x() + c * n.y(), n.z());
  return best;
}

bool VehicleBody::crosses(const GroundBox& box, const Eigen::Vector3d& origin,
                          const Eigen::Vector3d& direction, double min_range, double max_range) const
{
  Eigen::Vector3d o, d;
  toBoxFrame(box, origin, direction, o, d);
  for (const Part* part : {&lower_, &upper_})
  {
    const Crossing c = clip(*part, o, d);
    if (c.hit() && c.t_in > min_range && c.t_in <= max_range)
    {
      return true;
    }
  }
  return false;
}

RayHit intersectShape(const GroundBox& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                      double min_range, double glass_draw)
{
  if (box.shape == VehicleShape::kBox)
  {
    return intersectBox(box, origin, direction, min_range);
  }
  return VehicleBody(box.shape, box.length, box.width, box.height)
      .intersect(box, origin, direction, min_range, glass_draw, box.glass_transmission);
}

bool GroundSurface::profiled() const
{
  return camber != 0.0 || kerb_height != 0.0 || verge_rise_left != 0.0 || verge_rise_right != 0.0;
}

double GroundSurface::z(double x, double y) const
{
  const double plane = height + slope_x * x;
  if (!profiled())
  {
    return plane;
  }
  const double lateral = y - center_y;
  const double off = std::abs(lateral);
  if (off <= half_width)
  {
    return plane - camber * off;
  }
  const double rise = lateral > 0.0 ? verge_rise_left : verge_rise_right;
  return plane - camber * half_width + kerb_height + rise * std::min(1.0, (off - half_width) / verge_width);
}

RayHit GroundSurface::cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double min_range,
                           double max_range) const
{
  RayHit best;
  best.range = max_range;
  const double inf = std::numeric_limits<double>::infinity();
  const double hw = half_width, vw = verge_width, edge = kerb_height - camber * hw;
  const GroundStrip strips[] = {
      {-inf, -hw - vw, edge + verge_rise_right, 0.0},
      {-hw - vw, -hw, edge - verge_rise_right * hw / vw, -verge_rise_right / vw},
      {-hw, 0.0, 0.0, camber},
      {0.0, hw, 0.0, -camber},
      {hw, hw + vw, edge - verge_rise_left * hw / vw, verge_rise_left / vw},
      {hw + vw, inf, edge + verge_rise_left, 0.0},
  };
  for (const GroundStrip& strip : strips)
  {
    castStrip(*this, strip, origin, direction, min_range, best);
  }
  castKerb(*this, 1.0, origin, direction, min_range, best);
  castKerb(*this, -1.0, origin, direction, min_range, best);
  if (!best.hit())
  {
    return {};
  }
  return best;
}

void GroundSurface::validate() const
{
  if (!(half_width > 0.0))
  {
    throw std::invalid_argument("half_width must be > 0");
  }
  if (!(camber >= 0.0 && kerb_height >= 0.0 && verge_rise_left >= 0.0 && verge_rise_right >= 0.0))
  {
    throw std::invalid_argument("camber, kerb_height and the verge rises must be >= 0");
  }
  if (!(verge_width > 0.0))
  {
    throw std::invalid_argument("verge_width must be > 0");
  }
}

SceneSnapshot::SceneSnapshot(const std::vector<Actor>& actors, const std::vector<SceneryBox>& scenery,
                             double t, const GroundSurface& ground)
    : ground_(ground)
{
  for (const auto& actor : actors)
  {
    actor_boxes_.push_back(actor.boxAt(t));
    GroundBox& box = actor_boxes_.back();
    box.base_z = ground_.z(box.pose.x, box.pose.y);
    actor_active_.push_back(actor.activeAt(t));
    bound_radius_.push_back(boundingSphere(box).radius);
    actor_body_.push_back(-1);
    if (box.shape != VehicleShape::kBox)
    {
      actor_body_.back() = static_cast<int>(bodies_.size());
      bodies_.emplace_back(box.shape, box.length, box.width, box.height);
      has_glass_ = true;
    }
  }
  for (const auto& item : scenery)
  {
    scenery_boxes_.push_back(item.box);
    // Standing on the lowest ground under its footprint (a building on a verge or a slope).
    GroundBox& box = scenery_boxes_.back();
    double lowest = ground_.z(box.pose.x, box.pose.y);
    for (const Eigen::Vector3d& corner : box.corners())
    {
      lowest = std::min(lowest, ground_.z(corner.x(), corner.y()));
    }
    box.base_z += lowest;
    bound_radius_.push_back(boundingSphere(box).radius);
  }
  culled_.assign(bound_radius_.size(), false);
}

void SceneSnapshot::cullBeyond(const Eigen::Vector2d& centre, double radius)
{
  const std::size_t actors = actor_boxes_.size();
  for (std::size_t i = 0; i < culled_.size(); ++i)
  {
    const GroundBox& box = i < actors ? actor_boxes_[i] : scenery_boxes_[i - actors];
    culled_[i] = (Eigen::Vector2d(box.pose.x, box.pose.y) - centre).norm() - bound_radius_[i] > radius;
  }
}

RayHit SceneSnapshot::castActor(std::size_t i, const Eigen::Vector3d& origin,
                                const Eigen::Vector3d& direction, double min_range, double glass_draw) const
{
  const GroundBox& box = actor_boxes_[i];
  if (actor_body_[i] < 0)
  {
    return intersectBox(box, origin, direction, min_range);
  }
  double draw = glass_draw;
  if (draw < 1.0)
  {
    draw += kGolden * static_cast<double>(i);
    draw -= std::floor(draw);
  }
  return bodies_[static_cast<std::size_t>(actor_body_[i])].intersect(box, origin, direction, min_range, draw,
                                                                     box.glass_transmission);
}

RayHit SceneSnapshot::cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double min_range,
                           double max_range, double glass_draw) const
{
  RayHit best;
  if (ground_.profiled())
  {
    best = ground_.cast(origin, direction, min_range, max_range);
  }
  else
  {
    // Ground plane n · p = height with n = (−slope_x, 0, 1).
    const Eigen::Vector3d n(-ground_.slope_x, 0.0, 1.0);
    const double nd = n.dot(direction);
    if (nd < -1e-12)
    {
      const double t = (ground_.height - n.dot(origin)) / nd;
      if (t > min_range && t <= max_range)
      {
        best.range = t;
        best.object = RayHit::kGround;
        best.normal = n.normalized();
      }
    }
  }
  const std::size_t actors = actor_boxes_.size();
  for (std::size_t i = 0; i < actors + scenery_boxes_.size(); ++i)
  {
    if (culled_[i] || (i < actors && !actor_active_[i]))
    {
      continue;
    }
    const GroundBox& box = i < actors ? actor_boxes_[i] : scenery_boxes_[i - actors];
    const double limit = std::min(max_range, best.range);
    if (!mayHit(boundingSphere(box).centre, bound_radius_[i], origin, direction, min_range, limit))
    {
      continue;
    }
    RayHit hit = i < actors ? castActor(i, origin, direction, min_range, glass_draw)
                            : intersectBox(box, origin, direction, min_range);
    if (hit.range < best.range && hit.range <= max_range)
    {
      hit.object = i < actors ? static_cast<int>(i) : RayHit::kSceneryBase + static_cast<int>(i - actors);
      best = hit;
    }
  }
  return best;
}

void SceneSnapshot::actorsAlong(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                double min_range, double max_range, std::vector<int>& actors) const
{
  for (std::size_t i = 0; i < actor_boxes_.size(); ++i)
  {
    if (!actor_active_[i] || culled_[i] ||
        !mayHit(boundingSphere(actor_boxes_[i]).centre, bound_radius_[i], origin, direction, min_range,
                max_range))
    {
      continue;
    }
    const bool crosses = actor_body_[i] < 0
                             ? intersectBox(actor_boxes_[i], origin, direction, min_range).range <= max_range
                             : bodies_[static_cast<std::size_t>(actor_body_[i])].crosses(
                                   actor_boxes_[i], origin, direction, min_range, max_range);
    if (crosses)
    {
      actors.push_back(static_cast<int>(i));
    }
  }
}

std::vector<double> LidarConfig::hdl64Elevations()
{
  std::vector<double> elevations;
  for (int i = 0; i < 32; ++i)
  {
    elevations.push_back((2.0 - i / 3.0) * kDegToRad);
  }
  for (int i = 0; i < 32; ++i)
  {
    elevations.push_back((-8.83 - i * 0.5) * kDegToRad);
  }
  return elevations;
}

void LidarConfig::validate() const
{
  if (azimuth_steps < 1)
  {
    throw std::invalid_argument("azimuth_steps must be >= 1");
  }
  if (!(min_range >= 0.0 && max_range > min_range))
  {
    throw std::invalid_argument("need 0 <= min_range < max_range");
  }
  if (!(range_noise_std >= 0.0))
  {
    throw std::invalid_argument("range_noise_std must be >= 0");
  }
  if (!(dropout >= 0.0 && dropout < 1.0))
  {
    throw std::invalid_argument("dropout must be in [0, 1)");
  }
}

std::vector<LidarPoint> simulateLidarScan(const SceneSnapshot& scene, const Eigen::Isometry3d& sensor_pose,
                                          const LidarConfig& config, std::mt19937& rng)
{
  config.validate();
  const std::vector<double> elevations =
      config.elevations.empty() ? LidarConfig::hdl64Elevations() : config.elevations;
  std::normal_distribution<double> noise(0.0, config.range_noise_std);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const Eigen::Matrix3d rotation = sensor_pose.linear();
  const Eigen::Vector3d origin = sensor_pose.translation();
  const bool glass = scene.hasGlass();
  std::vector<LidarPoint> points;
  points.reserve(static_cast<std::size_t>(config.azimuth_steps) * elevations.size());
  for (int a = 0; a < config.azimuth_steps; ++a)
  {
    const double azimuth = M_PI - 2.0 * M_PI * a / config.azimuth_steps;  // from the back, clockwise
    const double ca = std::cos(azimuth);
    const double sa = std::sin(azimuth);
    for (double elevation : elevations)
    {
      const Eigen::Vector3d local(std::cos(elevation) * ca, std::cos(elevation) * sa, std::sin(elevation));
      const Eigen::Vector3d direction = rotation * local;
      // Draw every random number for every ray so that the stream does not depend on the hits
      // (the glass draw only where the scene has windows: other scenes' streams stay as they were).
      const double glass_draw = glass ? uniform(rng) : 1.0;
      const RayHit hit = scene.cast(origin, direction, config.min_range, config.max_range, glass_draw);
      const double drop = uniform(rng);
      const double range_noise = config.range_noise_std > 0.0 ? noise(rng) : 0.0;
      if (!hit.hit() || drop < config.dropout)
      {
        continue;
      }
      const double range = std::max(config.min_range, hit.range + range_noise);
      const double incidence = std::abs(hit.normal.dot(direction));
      const double intensity = std::clamp((0.15 + 0.85 * incidence) * std::exp(-range / 80.0), 0.0, 1.0);
      points.push_back({static_cast<float>(local.x() * range), static_cast<float>(local.y() * range),
                        static_cast<float>(local.z() * range), static_cast<float>(intensity)});
    }
  }
  return points;
}

}  // namespace grid_vision_fusion
