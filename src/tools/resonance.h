// `mjstepper resonance-test MODEL --axis x|y`: Klipper's TEST_RESONANCES on a simulated printer
// (issue 18, SPEC §9). The toolhead is moved back and forth along one axis with a rising frequency
// (resonance_excitation.h) through the printer's steppers, a virtual ADXL345 on the toolhead
// (sensors/adxl345.h) records it, and the command writes
//   PREFIX_raw.csv   the accelerometer log in Klipper's raw format: the first line
//                    `#time,accel_x,accel_y,accel_z`, then one row per sample, time in s,
//                    acceleration in mm/s² (Klipper's own scripts read it unchanged);
//   PREFIX_psd.csv   the frequency response in Klipper's calibration CSV, as
//                    `calibrate_shaper.py --csv` writes it and reads it back: the header
//                    `freq,psd_x,psd_y,psd_z,psd_xyz,shapers:,mzv(61.8),…`, then freq in Hz, the
//                    PSDs (Welch) normalized as Klipper keeps them, (mm/s²)²/Hz divided by
//                    f + 0.1 Hz, an empty column, and each fitted shaper's remaining vibration on
//                    the tested axis (a fraction, the worst over the test damping ratios);
//   PREFIX.png       the PSDs with each shaper's response, as users know the plot;
// and prints each shaper's fit and the recommendation.
//
// The model says how its steppers move the toolhead: for each stepper actuator NAME, a
//   <custom><numeric name="mjstepper:kinematics:NAME" data="kx ky kz"/></custom>
// gives its rotor angle per metre of toolhead motion along the printer's X, Y, Z (rad/m): a belt
// axis on a pulley of radius r has 1/r; CoreXY's A and B have (1/r, 1/r, 0) and (1/r, −1/r, 0) up
// to sign. The accelerometer is a MuJoCo `accelerometer` sensor (default name `toolhead_accel`)
// whose site's axes are the printer's X, Y, Z: the ADXL345 mounted square to the axes (Klipper's
// `axes_map: x, y, z`). Its reading includes gravity (+9.81 m/s² up), as the real part's does.
#ifndef MJSTEPPER_TOOLS_RESONANCE_H_
#define MJSTEPPER_TOOLS_RESONANCE_H_

#include <iosfwd>
#include <string>
#include <vector>

#include "config_overrides.h"
#include "core/resonance_excitation.h"
#include "core/sensors/adxl345.h"
#include "core/shaper.h"

namespace mjstepper::tools {

struct ResonanceOptions {
  std::string model;
  char axis = 'x';            ///< 'x' or 'y'
  ResonanceTestOptions test;  ///< SI: Hz, m/s² per Hz, Hz/s
  std::string accelerometer = "toolhead_accel";
  Adxl345Options adxl;                    ///< rate, range, noise, seed
  std::string out;                        ///< prefix of the three files
  std::vector<ConfigOverride> overrides;  ///< --set
  bool progress = true;
};

struct ResonanceResult {
  std::vector<double> frequency;  ///< Hz, the PSD's bins in the tested band
  std::vector<double> psd;        ///< (m/s²)²/Hz on the tested axis
  double peak_frequency = 0;      ///< Hz, the tested axis' largest PSD bin
  std::vector<ShaperFit> fits;    ///< one per shaper type
  int recommended = -1;           ///< index into fits
  long samples = 0;               ///< accelerometer samples written
  /// What makes the fits doubtful, for the user (PlacementWarnings): an accelerometer that does
  /// not move with the tested axis, a peak not above the sensor's noise floor.
  std::vector<std::string> warnings;
};

/// Writes ADXL345 samples to `path` in Klipper's raw format (the header above, s and mm/s²),
/// whole or not at all.
void WriteKlipperAccelLog(const std::string& path, const std::vector<AccelSample>& samples);

/// Throws std::runtime_error or std::invalid_argument with a message for the user.
ResonanceResult RunResonanceTest(const ResonanceOptions& options, std::ostream& progress);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_RESONANCE_H_
