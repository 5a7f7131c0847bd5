#pragma once
// Constants shared by the flight model, the race task and the tools: one place each.
namespace f16race::dynamics {

inline constexpr double kPi = 3.141592653589793;
inline constexpr double kDegToRad = kPi / 180.0;
inline constexpr double kG = 32.17;  // gravity [ft/s^2], AeroBench's value (subf16_model.py)

}  // namespace f16race::dynamics
