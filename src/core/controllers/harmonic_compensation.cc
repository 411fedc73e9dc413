#include "core/controllers/harmonic_compensation.h"

#include <fmt/format.h>

#include <sstream>

namespace mjstepper {

HarmonicCompensation HarmonicCompensation::FromAttributes(const AttributeSource& a,
                                                          const MotorParams& motor) {
  const std::vector<DetentHarmonic> estimates =
      a.Harmonics(kAttrDampingDetent).value_or(motor.detent);
  const std::optional<std::string> raw = a.Raw(kAttrDamping);
  if (!raw || *raw == "none") return {};
  if (*raw == "all") return {estimates};
  HarmonicCompensation selected;
  std::stringstream fields(*raw);
  std::string field;
  while (fields >> field) {
    double order = 0;
    if (!ParseFiniteDouble(field, &order)) {
      ThrowBad(kAttrDamping, *raw, "expected none, all, or harmonic orders such as \"4 2 1\"");
    }
    for (const DetentHarmonic& h : selected.harmonics) {
      if (h.order == order) {
        ThrowBad(kAttrDamping, *raw, fmt::format("harmonic {} is named twice", field));
      }
    }
    bool found = false;
    for (const DetentHarmonic& h : estimates) {
      if (h.order == order) {
        selected.harmonics.push_back(h);
        found = true;
      }
    }
    if (!found) {
      ThrowBad(kAttrDamping, *raw,
               fmt::format("harmonic {} is not in damping_detent (nor the motor's detent)", field));
    }
  }
  return selected;
}

}  // namespace mjstepper
