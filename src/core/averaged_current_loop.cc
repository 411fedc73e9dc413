#include "core/averaged_current_loop.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace mjstepper {

namespace {

// Terms of a piece's sums: the setpoint with the integrator, two per damping harmonic, the
// back-EMF's and the transient.
constexpr int kTerms = 3 + 2 * kAveragedLoopHarmonics;

// The most rotation (rad) between two samples at which a piece's voltage is checked against the
// stage's range.
constexpr double kSampleRotation = 0.5;
constexpr int kMaxSamples = 64;

// A piece's currents i(t) = Σk ik·e^{rk·t} and voltage v(t) = Σk vk·e^{rk·t} over [0, h], and
// for the integrator the setpoint's dq parts dk (zero but for the setpoint's terms).
struct Piece {
  PhaseVector rate[kTerms], current[kTerms], voltage[kTerms], setpoint[kTerms];
  PhaseVector end[kTerms];  // e^{rk·h}
  int n = 0;

  int Add(PhaseVector r, PhaseVector i, PhaseVector v, PhaseVector d) {
    rate[n] = r, current[n] = i, voltage[n] = v, setpoint[n] = d;
    return n++;
  }
};

// ∫0^h e^{(conj(rk) + rl)·t} dt, from e^{(conj(rk) + rl)·h} = conj(e^{rk·h})·e^{rl·h}.
PhaseVector PairIntegral(const Piece& p, int k, int l, double h) {
  const PhaseVector r = std::conj(p.rate[k]) + p.rate[l];
  return IntegralOfExp(r, h, std::conj(p.end[k]) * p.end[l], [r] { return 1.0 / r; });
}

}  // namespace

// The transient's rate (averaged_current_loop.h): the root of L·λ + R + Kp·G(λ) = 0 at λ = −α.
// Faster than (R + Kp)/L: the sampled loop reacts to the
// error it read τ before, when it was larger (Tsui's loop: 4 740 1/s against 3 818; the digital
// loop's dominant pole, −ln(z)/T, is 4 752). By Newton's method from (R + Kp)/L, which converges
// from below (f is convex); where the delay leaves no real root (Kp·τ comparable with L: the loop
// rings), or Newton does not settle, (R + Kp)/L.
LoopTransient TransientRate(double R, double L, double kp, double period, double lag) {
  const LoopTransient undelayed{.rate = (R + kp) / L, .per_ohm = 1 / L};
  double alpha = undelayed.rate;
  for (int i = 0; i < 16; ++i) {
    const double x = 0.5 * alpha * period;
    const double held = x < 1e-4 ? 1 + x * x / 6 : std::sinh(x) / x;         // sinh(x)/x
    const double held_slope = x < 1e-4 ? x / 3 : (std::cosh(x) - held) / x;  // d/dx
    const double delay = std::exp(alpha * lag);
    const double f = R + kp * delay * held - L * alpha;
    const double slope = kp * delay * (lag * held + 0.5 * period * held_slope) - L;  // ∂f/∂α
    if (!(slope < 0)) return undelayed;  // past the minimum: no root on this side
    const double next = alpha - f / slope;
    if (std::abs(next - alpha) <= 1e-12 * alpha) return {.rate = next, .per_ohm = -1 / slope};
    alpha = next;
  }
  return undelayed;
}

AveragedLoopResult AdvanceAveragedLoop(const MicrostepSetpoint& setpoint, const DqCurrentLoop& loop,
                                       const DriveConstants& k, const MotorParams& motor,
                                       const PowerStage& stage, const AveragedLoopStep& step,
                                       PhaseVector current0, PhaseVector* integral_dq) {
  AveragedLoopResult result;
  const double R = motor.resistance, L = motor.inductance;  // Ω, H: the winding's own
  const double nr = k.rotor_teeth;
  const double period = k.isr_period;                    // T, s
  const double lag = step.compute_delay + 0.5 * period;  // τ = D + T/2, s
  const double kp = loop.kp;                             // V/A
  const double ki = loop.ki_per_tick / period;           // V/(A·s)
  const double wc = nr * step.omega_frame;               // Ωc, rad/s
  const double w = nr * step.omega;                      // Ω, rad/s
  const std::vector<DetentHarmonic>& harmonics = setpoint.damping.harmonics;

  // The table's staircase: piece by piece between the lagged command's crossings, or (more than
  // kAveragedLoopPieces of them in the step, or no table) a continuous frame.
  const int microsteps = setpoint.microsteps;
  const double microstep = microsteps > 0 ? std::numbers::pi / 2 / microsteps : 0.0;  // Δψ, rad
  auto lagged_angle = [&](double t) {  // Nr·θcmd(t − τ), electrical rad
    return nr * (step.theta_frame + step.omega_frame * (t - lag));
  };
  const bool staircase = microsteps > 0 && std::abs(wc) * step.h <= kAveragedLoopPieces * microstep;
  const double fundamental = microsteps > 0 && !staircase ? Sinc(0.5 * microstep) : 1.0;
  // The next crossing of a half microstep by the lagged command after t, or h.
  auto piece_end = [&](double t) {
    if (!staircase || wc == 0) return step.h;
    const double x = lagged_angle(t) / microstep, rate = wc / microstep;  // microsteps, 1/s
    double half = rate > 0 ? std::floor(x + 0.5) + 0.5 : std::ceil(x - 0.5) - 0.5;
    if (!((half - x) / rate > 1e-12 * step.h)) half += rate > 0 ? 1 : -1;
    return std::min(step.h, t + (half - x) / rate);
  };

  // The frame's speed, its parts' lead over the lagged command, the hold's sinc at Ωf.
  const double frame_speed = staircase ? 0.0 : wc;  // Ωf, rad/s
  const PhaseVector lead = UnitPhasor(wc * lag);    // e^{jΩc·τ}
  const double frame_sinc = Sinc(0.5 * frame_speed * period);
  // The feedback −Kp·i(t_k), held from t_k + D over T, for a current part turning at μ: its
  // fundamental −Kp·sinc(μ·T/2)·e^{−jμτ}·i(t) (the frame's rotation cancels: the loop reads and
  // writes the current in the same ψk). Exact for each forced part; the transient meets it at its
  // own rate: α = (R + Kp·G(−α))/L (TransientRate).
  auto feedback = [&](double mu) {  // G(μ)
    return mu == wc ? Sinc(0.5 * mu * period) * std::conj(lead)
                    : Sinc(0.5 * mu * period) * UnitPhasor(-mu * lag);
  };
  const double alpha = step.transient_rate > 0 ? step.transient_rate
                                               : TransientRate(R, L, kp, period, lag).rate;  // 1/s
  PhaseVector current = current0;
  PhaseVector integral = *integral_dq;                                       // s, V (dq)
  PhaseVector phasor = step.rotor_phasor;                                    // e^{jx(t)}
  const PhaseVector emf_coefficient(0, motor.torque_constant * step.omega);  // e = j·Km·ω·e^{jx}
  double t = 0;
  while (t < step.h) {
    const double t_end = piece_end(t);
    const double h = t_end - t;  // s
    // The piece's frame: held at the table's entry, or turning with the lagged command.
    const double phase0 = lagged_angle(t);  // Nr·θcmd(t − τ)
    const double frame0 = staircase ? setpoint.Angle(k, (lagged_angle(t + 0.5 * h)) / nr) : phase0;
    const PhaseVector frame = UnitPhasor(frame0);
    const PhaseVector start = current;  // A
    bool linear = alpha > 0;

    Piece p;
    // A known voltage part c·e^{jμt} (before the hold's sinc), setpoint part d in dq.
    auto add_known = [&](double mu, double sinc, PhaseVector c, PhaseVector d) {
      const PhaseVector held = sinc * c;  // V
      const PhaseVector loop = kp * feedback(mu);
      const PhaseVector i = held / (PhaseVector(R, mu * L) + loop);
      p.Add({0, mu}, i, held - loop * i, d);
    };
    // Id (T(12)) and the held iq* with the integrator: e^{jψ}·(Kp·(Id + j·iq*) + s).
    const PhaseVector held_dq = fundamental * PhaseVector(setpoint.hold_current, step.iq);  // A
    add_known(frame_speed, frame_sinc, frame * (kp * held_dq + fundamental * integral), held_dq);
    // iq* of T(13): j·(A/Km)·sin(n·x + φ) = (A/2Km)·(e^{j(n·x + φ)} − e^{−j(n·x + φ)}).
    for (const DetentHarmonic& hm : harmonics) {
      const double amplitude = fundamental * hm.amplitude / (2 * k.torque_constant);  // A
      const PhaseVector rotation = UnitPhasor(hm.order * phase0 + hm.phase);
      const PhaseVector unlagged = rotation * UnitPhasor(hm.order * wc * lag);
      const double up = frame_speed + hm.order * wc, down = frame_speed - hm.order * wc;
      add_known(up, Sinc(0.5 * up * period), frame * kp * amplitude * rotation,
                amplitude * unlagged);
      add_known(down, Sinc(0.5 * down * period), -frame * kp * amplitude * std::conj(rotation),
                -amplitude * std::conj(unlagged));
    }
    const int emf = [&] {  // the back-EMF's part
      const PhaseVector loop = kp * feedback(w);
      const PhaseVector i = -emf_coefficient * phasor / (PhaseVector(R, w * L) + loop);
      return p.Add({0, w}, i, -loop * i, 0.0);
    }();
    PhaseVector transient = current;
    for (int j = 0; j < p.n; ++j) transient -= p.current[j];
    p.Add(-alpha, transient, (R - L * alpha) * transient, 0.0);  // Kp·G(−α) = L·α − R

    // The voltage at samples at most kSampleRotation apart, each within the stage's range; the
    // exponentials at the piece's end from the samples' steps.
    double fastest = 0;  // rad/s
    for (int j = 0; j < p.n; ++j) fastest = std::max(fastest, std::abs(p.rate[j].imag()));
    const int samples =
        std::clamp(static_cast<int>(std::ceil(fastest * h / kSampleRotation)), 1, kMaxSamples);
    const double dt = h / samples;  // s
    PhaseVector factor[kTerms];
    for (int j = 0; j < p.n; ++j) {
      const PhaseVector r = p.rate[j];
      if (j == emf && samples == 1 && h == step.h) {  // the rotor's own turn over the step
        factor[j] = step.rotor_phasor_end * std::conj(step.rotor_phasor);
      } else {
        factor[j] = r.real() == 0 ? UnitPhasor(r.imag() * dt) : std::exp(r * dt);
      }
      p.end[j] = 1.0;
    }
    for (int s = 0; s <= samples && linear; ++s) {
      PhaseVector v = 0;
      for (int j = 0; j < p.n; ++j) {
        v += p.voltage[j] * p.end[j];
        if (s < samples) p.end[j] *= factor[j];
      }
      if (stage.Apply(v).saturated) linear = false;
    }

    if (linear) {
      ++result.pieces;
      PhaseVector voltage = 0, frame_integral = 0;
      current = 0;
      for (int j = 0; j < p.n; ++j) {
        current += p.current[j] * p.end[j];
        voltage += p.voltage[j] * p.end[j];
      }
      // ∫e dt in dq (T(9)-(10)): the setpoint less e^{−jψ(t)}·i(t), ψ(t) = ψ0 + Ωc·τ + Ωf·t,
      // as the interrupts sample them: at the command's own time, not the lagged one (for a
      // held table frame, Ωc·τ is the mean lead of the unlagged frame over the piece). So the
      // integrator holds the sampled current on the command, as the digital loop's does.
      const PhaseVector sampled = std::conj(frame * lead);  // e^{−j(ψ0 + Ωc·τ)}
      const PhaseVector back = std::conj(p.end[0]);         // e^{−jΩf·h}: term 0 turns at Ωf
      for (int j = 0; j < p.n; ++j) {
        const PhaseVector r = p.rate[j] - PhaseVector(0, frame_speed);
        const PhaseVector e = IntegralOfExp(r, h, p.end[j] * back, [r] { return 1.0 / r; });
        frame_integral += (p.setpoint[j] - sampled * p.current[j]) * e;
      }
      integral += ki * frame_integral;
      // S-8: copper R·∫|i|² and mechanical ∫Re(conj(e)·i) from the pairs' integrals (the
      // mechanical's, conj(e^{jΩt})·e^{rl·t}, are the copper's emf row); the input from the
      // balance the exact solution satisfies identically, ∫v·i = copper + mechanical + Δ(L|i|²/2).
      double norm_integral = 0;
      PhaseVector rotor_integral = 0;
      for (int j = 0; j < p.n; ++j) {
        const PhaseVector own = PairIntegral(p, j, j, h);  // ∫e^{2·Re(rj)·t}
        norm_integral += std::norm(p.current[j]) * own.real();
        if (j == emf) rotor_integral += p.current[j] * own;
        for (int l = j + 1; l < p.n; ++l) {
          const PhaseVector pair = PairIntegral(p, j, l, h);
          norm_integral += 2 * (std::conj(p.current[j]) * p.current[l] * pair).real();
          if (j == emf) rotor_integral += p.current[l] * pair;
          if (l == emf) rotor_integral += p.current[j] * std::conj(pair);
        }
      }
      const double copper = R * norm_integral;
      const double mechanical = (std::conj(emf_coefficient * phasor) * rotor_integral).real();
      result.energy.copper += copper;
      result.energy.mechanical += mechanical;
      result.energy.input +=
          copper + mechanical + 0.5 * L * (std::norm(current) - std::norm(start));
      phasor *= p.end[emf];
      result.voltage = voltage;
    } else {
      // The bus cuts the request: the interrupts' own loop from the piece's start, a tick each
      // period T whose voltage applies D later (until then the one before: at the first, the
      // closed form's), each held interval on the exact winding solution.
      PhaseVector held = 0;  // V
      for (int j = 0; j < p.n; ++j) held += p.voltage[j];
      held = stage.Apply(held).voltage;
      auto advance = [&](double length, PhaseVector voltage) {
        if (!(length > 0)) return;
        const WindingKernel kernel(motor, step.omega, length);
        IntervalEnergy e;
        current = AdvanceInterval(motor, kernel, current, voltage, phasor, &e);
        phasor *= kernel.rotation;
        result.energy.input += e.input;
        result.energy.copper += e.copper;
        result.energy.mechanical += e.mechanical;
      };
      for (double u = t; u < t_end; u += period) {
        const double length = std::min(period, t_end - u);  // s
        // The tick of T(9)-(11) in the frame at u, its integrator moving by the share of Ki·e
        // its held voltage lasts (the last may be cut short by the piece's end).
        const double theta_frame = step.theta_frame + step.omega_frame * u;  // rad
        const PhaseVector target = setpoint.Dq(k, theta_frame) + PhaseVector(0, step.iq);
        const PhaseVector park = UnitPhasor(setpoint.Angle(k, theta_frame));
        const DqCurrentLoop share{.kp = kp, .ki_per_tick = length / period * loop.ki_per_tick};
        const BridgeOutput out = share.Update(target, park, current, stage, &integral);
        const double delay = std::min(step.compute_delay, length);  // s
        advance(delay, held);
        advance(length - delay, out.voltage);
        held = out.voltage;
        ++result.held;
      }
      result.voltage = held;
    }
    t = t_end;
  }
  *integral_dq = integral;
  result.current = current;
  return result;
}

}  // namespace mjstepper
