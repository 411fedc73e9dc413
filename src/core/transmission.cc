#include "core/transmission.h"

#include <fmt/format.h>

namespace mjstepper {

std::string Transmission::CarriageText() const {
  if (pulley_teeth > 0) {
    return fmt::format("pulley_teeth = {}, belt_pitch = {:g} m ({:g} mm per turn)", pulley_teeth,
                       belt_pitch, TravelPerRevolution() * 1e3);
  }
  if (lead > 0) return fmt::format("lead = {:g} m ({:g} mm per turn)", lead, lead * 1e3);
  return "";
}

}  // namespace mjstepper
