// One scene taking another in: two sites that grew together become one.
// The other's photos, pairs, points and components join this scene,
// renumbered after its own, and move from the other's ENU frame into this
// one's (exactly, through geodetic coordinates: the origins may be
// hundreds of metres apart).
#include <Eigen/SVD>

#include "scene/scene.h"

namespace arscout::engine {
namespace {

// From the other scene's ENU frame to this one's: x -> R x + t, from the
// images of the three unit axes (the frames differ by the earth's
// curvature between the origins, a rotation of microradians per metre; a
// metre's step is linear to far below a micrometre).
struct FrameChange {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  Eigen::Vector3d apply(const Eigen::Vector3d& x) const { return R * x + t; }
};

Eigen::Vector3d moved(const EnuFrame& from, const EnuFrame& to,
                      const Eigen::Vector3d& x) {
  const auto enu = to.to_enu(from.to_geodetic({x.x(), x.y(), x.z()}));
  return {enu[0], enu[1], enu[2]};
}

FrameChange frame_change(const Geodetic& from_origin,
                         const Geodetic& to_origin) {
  const EnuFrame from(from_origin), to(to_origin);
  FrameChange change;
  change.t = moved(from, to, Eigen::Vector3d::Zero());
  Eigen::Matrix3d axes;
  for (int i = 0; i < 3; ++i)
    axes.col(i) = moved(from, to, Eigen::Vector3d::Unit(i)) - change.t;
  // The nearest rotation (the axes are orthonormal to rounding).
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      axes, Eigen::ComputeFullU | Eigen::ComputeFullV);
  change.R = svd.matrixU() * svd.matrixV().transpose();
  return change;
}

// The other scene's camera indices in this one: a camera of the same id
// (the same physical camera, undistorted the same way) is shared.
std::vector<int> join_cameras(Scene& into, const Scene& other) {
  std::vector<int> index;
  for (const SceneCamera& camera : other.cameras) {
    int found = -1;
    for (size_t i = 0; i < into.cameras.size(); ++i) {
      if (into.cameras[i].id == camera.id &&
          into.cameras[i].scale == camera.scale &&
          into.cameras[i].original.width == camera.original.width &&
          into.cameras[i].original.height == camera.original.height)
        found = static_cast<int>(i);
    }
    if (found < 0) {
      found = static_cast<int>(into.cameras.size());
      into.cameras.push_back(camera);
    }
    index.push_back(found);
  }
  return index;
}

}  // namespace

void absorb_scene(Scene& into, Scene&& other) {
  if (!into.enu_origin) into.enu_origin = other.enu_origin;
  const FrameChange change =
      other.enu_origin ? frame_change(*other.enu_origin, *into.enu_origin)
                       : FrameChange{};
  const Eigen::Quaterniond turn(change.R);
  const EnuFrame frame(*into.enu_origin);
  const int image_offset = static_cast<int>(into.images.size());
  const int64_t point_offset = into.next_point_id;
  const int component_offset = into.next_component;
  const std::vector<int> cameras = join_cameras(into, other);
  for (SceneImage& image : other.images) {
    image.camera = cameras[image.camera];
    image.component += component_offset;
    for (int64_t& point : image.point_of)
      if (point >= 0) point += point_offset;
    if (image.gps) {
      const auto enu =
          frame.to_enu({image.gps->lat, image.gps->lon,
                        image.gps->alt.value_or(frame.origin().alt)});
      image.gps_enu = {enu[0], enu[1], enu[2]};
    }
    if (image.registered) {
      // World-to-camera: x_cam = R x_other + t, x_other = R_c^T (x - t_c).
      const Eigen::Vector3d centre = change.apply(image.centre());
      image.q = (image.q * turn.conjugate()).normalized();
      image.t = -(image.q * centre);
    }
    into.images.push_back(std::move(image));
  }
  for (auto& [key, pair] : other.pairs)
    into.pairs[{key.first + image_offset, key.second + image_offset}] =
        std::move(pair);
  for (auto& [id, point] : other.points) {
    point.xyz = change.apply(point.xyz);
    for (Observation& obs : point.track) obs.image += image_offset;
    into.points[id + point_offset] = std::move(point);
  }
  into.next_point_id += other.next_point_id;
  into.next_component += other.next_component;
  if (!into.initialized && other.initialized) {
    into.initialized = true;
    into.geo_registered = other.geo_registered;
    into.reference_image =
        other.reference_image >= 0 ? other.reference_image + image_offset : -1;
    into.scale_image =
        other.scale_image >= 0 ? other.scale_image + image_offset : -1;
  }
  into.registered_at_last_global_ba = 0;  // the refinement is due
  into.merge_sweep_due = true;
}

}  // namespace arscout::engine
