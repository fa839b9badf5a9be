// The closed loop of Fig. 2 for given wall gains: the exact one-period transition of the loop
// state and the unit-step initial condition, in deviation coordinates.
//
// Wall force (backward difference): f_j = alpha x_j + beta (x_j - x_{j-1}). Step input F = 1 at
// t = 0 from rest (x = 0, no earlier forces); final position x_inf = 1 / (alpha + gamma).
// Loop state e_j = (x_j - x_inf, x'_j, x_{j-1} - x_inf, ..., x_{j-H} - x_inf), e_{j+1} = M e_j,
// e_0 = -x_inf (1, 0, 1, ..., 1). On segment s of period j the augmented state is xi = R_s e_j.
#pragma once

#include <Eigen/Core>
#include <array>

#include "sampled_plant.hpp"

namespace hapticopt {

template <typename Scalar>
using DynamicMatrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
template <typename Scalar>
using DynamicVector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;

template <typename Scalar>
struct ClosedLoop {
  Scalar alpha = 0;
  Scalar beta = 0;
  Scalar total_stiffness = 0;  ///< alpha + gamma (must be > 0 for a final position to exist)
  Scalar final_position = 0;   ///< x_inf = 1 / (alpha + gamma)
  DynamicMatrix<Scalar> transition;  ///< M, N x N
  DynamicVector<Scalar> initial_state;  ///< e_0
  std::array<DynamicMatrix<Scalar>, 2> segment_map;  ///< R_s, 3 x N
};

/// Builds M, e_0 and R_s. Cost O(N^2). Requires alpha + gamma != 0 (callers check stability,
/// which implies alpha + gamma > 0).
template <typename Scalar>
ClosedLoop<Scalar> make_closed_loop(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta) {
  const int n = plant.state_dimension();
  const int history = plant.history_length();
  ClosedLoop<Scalar> loop;
  loop.alpha = alpha;
  loop.beta = beta;
  loop.total_stiffness = alpha + Scalar(plant.parameters().gamma);
  loop.final_position = Scalar(1) / loop.total_stiffness;

  // Row of the deviation force u = f_{j-age} - f_inf as a function of e_j.
  auto force_row = [&](int age) {
    DynamicMatrix<Scalar> row = DynamicMatrix<Scalar>::Zero(1, n);
    row(0, SampledPlant<Scalar>::position_index(age)) += alpha + beta;
    row(0, SampledPlant<Scalar>::position_index(age + 1)) -= beta;
    return row;
  };

  DynamicMatrix<Scalar> plant_rows = DynamicMatrix<Scalar>::Zero(2, n);  // (x, x') at segment start
  plant_rows(0, 0) = 1;
  plant_rows(1, 1) = 1;
  for (int s = 0; s < plant.segment_count(); ++s) {
    const auto& seg = plant.segment(s);
    DynamicMatrix<Scalar> r(3, n);
    r.topRows(2) = plant_rows;
    r.row(2) = force_row(seg.force_age);
    plant_rows = seg.exp.template topRows<2>() * r;  // (x, x') at segment end
    loop.segment_map[static_cast<std::size_t>(s)] = r;
  }

  DynamicMatrix<Scalar>& m = loop.transition;
  m = DynamicMatrix<Scalar>::Zero(n, n);
  m.topRows(2) = plant_rows;
  for (int i = 0; i < history; ++i) {
    m(SampledPlant<Scalar>::position_index(i + 1), SampledPlant<Scalar>::position_index(i)) = 1;
  }

  loop.initial_state = DynamicVector<Scalar>::Constant(n, -loop.final_position);
  loop.initial_state(1) = 0;
  return loop;
}

}  // namespace hapticopt
