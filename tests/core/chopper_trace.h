// A chopper drive's phase-A trace on a rotor turned at a set speed, shared by the chopper and
// SpreadCycle tests.
#ifndef MJSTEPPER_TESTS_CORE_CHOPPER_TRACE_H_
#define MJSTEPPER_TESTS_CORE_CHOPPER_TRACE_H_

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/drive.h"

namespace mjstepper::testing {

struct Trace {
  std::vector<double> t, ia, va, ref_a;
};

// The drive on a rotor turning at ω (rad/s) from θ = 0, commanded at the same speed, stepped by h
// from t = 0 to t_end; samples recorded from t_record on.
inline Trace RunAtSpeed(const Drive& drive, double omega, double h, double t_end, double t_record) {
  DriveState s = drive.Rest(0.0, 0.0, omega);
  Trace tr;
  const long n = std::lround(t_end / h);
  for (long k = 0; k < n; ++k) {
    const double t0 = k * h, t1 = (k + 1) * h;
    EXPECT_EQ(drive.Advance(&s, t0, t1, omega * t1, omega), AdvanceStatus::kOk);
    if (t1 >= t_record) {
      tr.t.push_back(t1);
      tr.ia.push_back(s.current_a);
      tr.va.push_back(s.voltage_a);
      tr.ref_a.push_back(s.current_ref_a);
    }
  }
  return tr;
}

// RMS of i_a − i_a* over the samples, A.
inline double TrackingError(const Trace& tr) {
  double sum = 0;
  for (size_t k = 0; k < tr.t.size(); ++k) sum += std::pow(tr.ia[k] - tr.ref_a[k], 2);
  return std::sqrt(sum / tr.t.size());
}

}  // namespace mjstepper::testing

#endif  // MJSTEPPER_TESTS_CORE_CHOPPER_TRACE_H_
