#include "core/controllers/kim_mechanical.h"

#include "core/units.h"

namespace mjstepper {

double KimMechanical::Sensitivity(double frequency) const {
  const std::complex<double> s(0, kTwoPi * frequency);
  const auto [c2, c1, c0] = Characteristic();
  return std::abs(s / (s * s * s + c2 * s * s + c1 * s + c0));  // K(35) times J
}

}  // namespace mjstepper
