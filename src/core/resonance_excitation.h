// The excitation of a resonance test (issue 18, SPEC §9), as Klipper's TEST_RESONANCES describes
// it (Klipper documentation, "Measuring Resonances"): the toolhead moves back and forth along one
// axis with a frequency rising from min_freq to max_freq at hz_per_sec, each half cycle at the
// acceleration accel_per_hz·f. Here each back-and-forth cycle n starts at t_n with the frequency
// f_n = min_freq + hz_per_sec·t_n and lasts 1/f_n (so t_{n+1} = t_n + 1/f_n); within it the
// acceleration is a square wave ±A_n, A_n = accel_per_hz·f_n, so the velocity is the triangle
//   v = V·tri(u),  u = f_n·(t − t_n) ∈ [0, 1),  V = A_n/(4·f_n) = accel_per_hz/4,
//   tri(u) = 4u (u ≤ 1/4), 2 − 4u (u ≤ 3/4), 4u − 4,
// and the position its exact integral, (V/f_n)·g(u) with g = 2u², 2u − 2u² − 1/4, 2·(1 − u)²:
// from 0 out to accel_per_hz/(16·f_n) and back to 0 in every cycle, so the toolhead never drifts
// (a frequency changing within a cycle would make its two halves unequal, and the drift add up
// over thousands of cycles).
#ifndef MJSTEPPER_CORE_RESONANCE_EXCITATION_H_
#define MJSTEPPER_CORE_RESONANCE_EXCITATION_H_

namespace mjstepper {

struct ResonanceTestOptions {
  double min_freq = 5;          ///< Hz (Klipper's default)
  double max_freq = 133.33;     ///< Hz (Klipper's default)
  double accel_per_hz = 0.075;  ///< m/s² per Hz (Klipper's 75 mm/s²/Hz)
  double hz_per_sec = 1;        ///< Hz/s (Klipper's default)

  /// s: (max_freq − min_freq)/hz_per_sec.
  double Duration() const { return (max_freq - min_freq) / hz_per_sec; }
};

/// Throws std::invalid_argument naming the option, its value and its range.
void Validate(const ResonanceTestOptions& o);

/// The commanded position along the tested axis, stepped through time.
class ResonanceExcitation {
 public:
  explicit ResonanceExcitation(const ResonanceTestOptions& o);

  /// The current cycle's frequency f_n, Hz.
  double frequency() const { return frequency_; }
  /// Moves on by dt (s) and returns the position then, m (exact).
  double Advance(double dt);
  /// The velocity now, m/s.
  double Velocity() const;
  double time() const { return t_; }

 private:
  ResonanceTestOptions o_;
  double t_ = 0;            // s
  double cycle_start_ = 0;  // s, t_n
  double frequency_ = 0;    // Hz, f_n
};

}  // namespace mjstepper

#endif  // MJSTEPPER_CORE_RESONANCE_EXCITATION_H_
