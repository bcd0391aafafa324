#pragma once
// The one wavelength grid of the project (MODEL.md, "Colour"): 380-780 nm in
// 5 nm steps, 81 samples. Every spectrum inside the project lives on it.

namespace chromo::spectral {

inline constexpr double kGridStartNm = 380.0;
inline constexpr double kGridStepNm = 5.0;
inline constexpr int kGridSize = 81;
inline constexpr double kGridEndNm = kGridStartNm + kGridStepNm * (kGridSize - 1);

constexpr double grid_wavelength_nm(int index) { return kGridStartNm + kGridStepNm * index; }

}  // namespace chromo::spectral
