// Dimension-dependent vector types. A scene is instantiated for Dim = 2 or 3 and
// pays only for its own dimension: in 2D an angular velocity is a 1-vector (the
// z component), in 3D a 3-vector.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>

// Contact-law kernels are small and called once per contact: force inlining
// so that the pair loop is one flat function.
#define GRANULAR_INLINE inline __attribute__((always_inline))

namespace granular {

template <int Dim>
struct Space;

template <>
struct Space<3> {
  using Vec = Eigen::Vector3d;
  using Ang = Eigen::Vector3d;
  static constexpr int kAngDim = 3;
};

template <>
struct Space<2> {
  using Vec = Eigen::Vector2d;
  using Ang = Eigen::Matrix<double, 1, 1>;
  static constexpr int kAngDim = 1;
};

template <int Dim>
using Vec = typename Space<Dim>::Vec;
template <int Dim>
using Ang = typename Space<Dim>::Ang;

// omega x r : angular velocity times a position vector gives a velocity.
inline Eigen::Vector3d spin_cross(const Eigen::Vector3d& w, const Eigen::Vector3d& r) { return w.cross(r); }
inline Eigen::Vector2d spin_cross(const Eigen::Matrix<double, 1, 1>& w, const Eigen::Vector2d& r) {
  return {-w[0] * r.y(), w[0] * r.x()};
}

// r x f : a lever arm times a force gives a torque.
inline Eigen::Vector3d moment(const Eigen::Vector3d& r, const Eigen::Vector3d& f) { return r.cross(f); }
inline Eigen::Matrix<double, 1, 1> moment(const Eigen::Vector2d& r, const Eigen::Vector2d& f) {
  return Eigen::Matrix<double, 1, 1>(r.x() * f.y() - r.y() * f.x());
}

}  // namespace granular
