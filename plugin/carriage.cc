#include "carriage.h"

#include <fmt/format.h>

#include <cmath>

namespace mjstepper::plugin {
namespace {

std::string NameAt(const mjModel* m, int adr) { return adr >= 0 ? m->names + adr : ""; }

}  // namespace

Belt BeltOf(const mjModel* m, int hinge) {
  for (int tendon = 0; tendon < m->ntendon; ++tendon) {
    Belt belt{.tendon = tendon};
    bool slide = false;
    for (int w = m->tendon_adr[tendon]; w < m->tendon_adr[tendon] + m->tendon_num[tendon]; ++w) {
      if (m->wrap_type[w] != mjWRAP_JOINT) break;  // a spatial tendon
      if (m->wrap_objid[w] == hinge) belt.coef = m->wrap_prm[w];
      slide = slide || m->jnt_type[m->wrap_objid[w]] == mjJNT_SLIDE;
    }
    if (belt.coef != 0 && slide) return belt;
  }
  return {};
}

std::string CarriageMismatch(const mjModel* m, int a, const Transmission& t) {
  if (t.TravelPerRevolution() == 0) return "";
  const int target = m->actuator_trnid[2 * a];
  const bool joint = m->actuator_trntype[a] == mjTRN_JOINT;
  if (!joint || m->jnt_type[target] != mjJNT_HINGE) {
    return fmt::format(
        "{}: a carriage is declared on the turns of a hinge joint, and this stepper drives {} "
        "'{}', whose gear already gives rad per metre: remove it (profiles there take mm, mm/s "
        "as they are)",
        t.CarriageText(), joint ? "slide joint" : "tendon",
        NameAt(m, joint ? m->name_jntadr[target] : m->name_tendonadr[target]));
  }
  const double radius = t.MetresPerRadian();  // m/rad
  const Belt belt = BeltOf(m, target);
  if (belt.tendon >= 0 && std::abs(std::abs(belt.coef) - radius) > kCarriageTolerance * radius) {
    return fmt::format(
        "{}: a pitch radius of {:.5g} mm, but tendon '{}' winds joint '{}' at {:.5g} mm per rad "
        "(its coefficient): declare the pulley the belt turns, or correct the tendon",
        t.CarriageText(), radius * 1e3, NameAt(m, m->name_tendonadr[belt.tendon]),
        NameAt(m, m->name_jntadr[target]), std::abs(belt.coef) * 1e3);
  }
  return "";
}

}  // namespace mjstepper::plugin
