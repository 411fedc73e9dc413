#include "modes.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <stdexcept>

#include "core/drive.h"
#include "core/units.h"

namespace mjstepper::plugin {
namespace {

// One spring of the model: k·a·aᵀ in K, a over the dofs.
struct Spring {
  std::string name;
  double k = 0;
  Eigen::VectorXd a;
  int stepper = -1;  // index in the ModalStepper list, or -1
};

std::string NameOr(const mjModel* m, mjtObj type, int id, const char* kind) {
  const char* name = mj_id2name(m, type, id);
  return name != nullptr && name[0] != '\0' ? fmt::format("{} '{}'", kind, name)
                                            : fmt::format("{} id {}", kind, id);
}

// A sparse row (MuJoCo's CSR: nnz values from adr, columns in colind) as a dense vector.
Eigen::VectorXd DenseRow(int nv, int nnz, int adr, const int* colind, const mjtNum* values) {
  Eigen::VectorXd row = Eigen::VectorXd::Zero(nv);
  for (int k = adr; k < adr + nnz; ++k) row(colind[k]) += values[k];
  return row;
}

// Equalities and the limits active at the pose hold; contacts do not. Two reasons: MuJoCo's
// compiler makes the first mjData (whose plugin init runs the load check) with contacts disabled
// (user_model.cc sets mjDSBL_CONTACT around mj_setConst), so the plugin could never see them
// while the tools, later, did (PAROL6's base and link 1 meshes touch at qpos0: the load check
// found a mode the tools did not); and holding a constraint can only lower the highest
// frequency (the constrained pencil's eigenvalues interlace the free one's, Cauchy), so leaving
// a contact free judges the timestep on the safe side. A contact at the start pose is also
// circumstantial: the motion leaves it.
bool Held(int type) {
  return type == mjCNSTR_EQUALITY || type == mjCNSTR_LIMIT_JOINT || type == mjCNSTR_LIMIT_TENDON;
}

}  // namespace

bool Mode::stepper() const {
  const auto counts = [](double p) { return p >= kMinParticipation; };
  return std::any_of(participation.begin(), participation.end(), counts) ||
         std::any_of(rotor_motion.begin(), rotor_motion.end(), counts);
}

std::vector<Mode> ComputeModes(const mjModel* m, const std::vector<ModalStepper>& steppers, int key,
                               bool worst_case) {
  const int nv = m->nv;
  if (nv == 0) return {};
  struct DataDeleter {
    void operator()(mjData* d) const { mj_deleteData(d); }
  };
  const std::unique_ptr<mjData, DataDeleter> data(mj_makeData(m));
  mjData* d = data.get();
  if (d == nullptr) throw std::runtime_error("modes: mj_makeData failed");
  if (key >= 0) mj_resetDataKeyframe(m, d, key);
  mj_fwdPosition(m, d);  // M, tendon and actuator Jacobians, active constraints; no plugin runs

  std::vector<mjtNum> dense(static_cast<size_t>(nv) * nv);
  mj_fullM(m, d, dense.data());
  const Eigen::MatrixXd mass = Eigen::Map<Eigen::MatrixXd>(dense.data(), nv, nv);  // symmetric

  std::vector<Spring> springs;
  for (int j = 0; j < m->njnt; ++j) {
    if ((m->jnt_type[j] == mjJNT_HINGE || m->jnt_type[j] == mjJNT_SLIDE) &&
        m->jnt_stiffness[j] > 0) {
      Spring s{.name = NameOr(m, mjOBJ_JOINT, j, "joint"),
               .k = m->jnt_stiffness[j],
               .a = Eigen::VectorXd::Zero(nv),
               .stepper = -1};
      s.a(m->jnt_dofadr[j]) = 1;
      springs.push_back(std::move(s));
    }
  }
  for (int t = 0; t < m->ntendon; ++t) {
    if (!(m->tendon_stiffness[t] > 0)) continue;
    springs.push_back(
        {.name = NameOr(m, mjOBJ_TENDON, t, "tendon"),
         .k = m->tendon_stiffness[t],
         .a = DenseRow(nv, m->ten_J_rownnz[t], m->ten_J_rowadr[t], m->ten_J_colind, d->ten_J)});
  }
  for (size_t i = 0; i < steppers.size(); ++i) {
    const ModalStepper& s = steppers[i];
    const int row = m->actuator_outadr[s.actuator];
    springs.push_back({.name = fmt::format("stepper '{}'", s.name),
                       .k = s.stiffness + (worst_case ? s.detent_stiffness : 0.0),
                       .a = DenseRow(nv, d->moment_rownnz[row], d->moment_rowadr[row],
                                     d->moment_colind, d->actuator_moment),
                       .stepper = static_cast<int>(i)});
  }

  // The free directions: the null space of the held constraints' Jacobian.
  std::vector<int> held;
  for (int r = 0; r < d->nefc; ++r) {
    if (Held(d->efc_type[r])) held.push_back(r);
  }
  Eigen::MatrixXd basis = Eigen::MatrixXd::Identity(nv, nv);
  if (!held.empty()) {
    Eigen::MatrixXd jac(held.size(), nv);
    for (size_t i = 0; i < held.size(); ++i) {
      const int r = held[i];
      if (mj_isSparse(m)) {
        jac.row(i) = DenseRow(nv, d->efc_J_rownnz[r], d->efc_J_rowadr[r], d->efc_J_colind, d->efc_J)
                         .transpose();
      } else {
        jac.row(i) = Eigen::Map<const Eigen::VectorXd>(d->efc_J + static_cast<size_t>(r) * nv, nv)
                         .transpose();
      }
    }
    const Eigen::BDCSVD<Eigen::MatrixXd> svd(jac, Eigen::ComputeFullV);  // Jacobi below 16 columns
    // Rank at Eigen's default threshold (ε·max(rows, cols)·σmax): rows that repeat a contact's
    // direction add nothing.
    const int rank = static_cast<int>(svd.rank());
    basis = svd.matrixV().rightCols(nv - rank);
  }
  const int n = static_cast<int>(basis.cols());
  if (n == 0) return {};
  const Eigen::MatrixXd reduced_mass = basis.transpose() * mass * basis;
  Eigen::MatrixXd reduced_stiffness = Eigen::MatrixXd::Zero(n, n);
  std::vector<Eigen::VectorXd> reduced_a;
  for (const Spring& s : springs) {
    reduced_a.push_back(basis.transpose() * s.a);
    reduced_stiffness += s.k * reduced_a.back() * reduced_a.back().transpose();
  }
  if (Eigen::LLT<Eigen::MatrixXd>(reduced_mass).info() != Eigen::Success) {
    throw std::runtime_error(
        "modes: the mass matrix is not positive definite in the free directions (a massless dof?)");
  }
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> solver(reduced_stiffness,
                                                                         reduced_mass);
  if (solver.info() != Eigen::Success) throw std::runtime_error("modes: eigensolver failed");
  const Eigen::VectorXd lambda = solver.eigenvalues();  // ω², increasing
  const double largest = std::max(lambda.maxCoeff(), 0.0);
  std::vector<Mode> modes;
  for (int k = 0; k < n; ++k) {
    // Rigid-body (and round-off) directions: ω² within 1e-12 of the largest, relatively.
    if (!(lambda(k) > 1e-12 * largest)) continue;
    const Eigen::VectorXd v = solver.eigenvectors().col(k);
    std::vector<double> energy(springs.size());
    for (size_t i = 0; i < springs.size(); ++i) {
      const double along = reduced_a[i].dot(v);
      energy[i] = springs[i].k * along * along;
    }
    const double total = std::accumulate(energy.begin(), energy.end(), 0.0);
    Mode mode;
    mode.omega = std::sqrt(lambda(k));
    mode.participation.assign(steppers.size(), 0.0);
    mode.rotor_motion.assign(steppers.size(), 0.0);
    const double kinetic = v.dot(reduced_mass * v);  // 2·T of the mode's shape
    std::string moved;  // the sub-stepped rotors it moves, for `springs`
    for (size_t i = 0; i < springs.size(); ++i) {
      const int j = springs[i].stepper;
      if (j < 0 || !steppers[j].substepped || !(kinetic > 0)) continue;
      const double along = reduced_a[i].dot(v);  // the rotor's share of the shape, rad
      mode.rotor_motion[j] = m->actuator_armature[steppers[j].actuator] * along * along / kinetic;
      if (mode.rotor_motion[j] >= kMinParticipation) {
        moved +=
            fmt::format("{}sub-stepped rotor '{}' moves {:.0f} % of its inertia",
                        moved.empty() ? "" : ", ", steppers[j].name, 100 * mode.rotor_motion[j]);
      }
    }
    std::vector<size_t> order(springs.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return energy[a] > energy[b]; });
    for (size_t i : order) {
      const double fraction = total > 0 ? energy[i] / total : 0;
      if (springs[i].stepper >= 0) mode.participation[springs[i].stepper] = fraction;
      if (fraction >= kMinParticipation) {
        mode.springs += fmt::format("{}{} {:.0f} %", mode.springs.empty() ? "" : ", ",
                                    springs[i].name, 100 * fraction);
      }
    }
    if (!moved.empty()) mode.springs += (mode.springs.empty() ? "" : "; ") + moved;
    if (!order.empty()) mode.dominant = springs[order.front()].name;
    modes.push_back(std::move(mode));
  }
  return modes;
}

RuleMode ToRuleMode(const Mode& mode, int index) {
  return {.omega = mode.omega,
          .name = fmt::format("mode {} ({})", index + 1, mode.springs),
          .stepper = mode.stepper()};
}

TimestepVerdict JudgeModelTimestep(const mjModel* m, const std::vector<ModalStepper>& steppers,
                                   int key) {
  std::vector<ModalStepper> judged = steppers;
  for (ModalStepper& s : judged) {
    if (s.substepped) s.stiffness = s.detent_stiffness = 0;
  }
  const std::vector<Mode> modes = ComputeModes(m, judged, key, /*worst_case=*/true);
  std::vector<RuleMode> rule;
  for (size_t i = 0; i < modes.size(); ++i)
    rule.push_back(ToRuleMode(modes[i], static_cast<int>(i)));
  // The strictest of the steppers' couplings (core/coupling.h, MaxOmegaTimesStep).
  double limit = kMaxOmegaTimesStep;
  for (const ModalStepper& s : steppers) limit = std::min(limit, s.max_omega_h);
  TimestepVerdict verdict = JudgeTimestep(rule, m->opt.timestep, limit);
  // A move's ringing with STEP/DIR input: on the fastest stepper mode with every stepper's
  // holding stiffness (the rotor rings on it whatever the coupling), as `info` lists the modes.
  if (std::any_of(steppers.begin(), steppers.end(),
                  [](const ModalStepper& s) { return s.step_input; })) {
    double fastest = 0;  // rad/s
    for (const Mode& mode : ComputeModes(m, steppers, key)) {
      if (mode.stepper()) fastest = std::max(fastest, mode.omega);
    }
    JudgeRinging(&verdict, fastest);
  }
  return verdict;
}

}  // namespace mjstepper::plugin
