#pragma once
// Derived float data of a finished session, from the stored frames only
// (so the same function serves a session re-processed later):
//  - derived/<step>-<camera>-mean.exr: the mean of the step's frames, in
//    units of full scale (0-1), channel "Y" for one-sample formats (Bayer
//    frames stay mosaicked), "R","G","B" for RGB8;
//  - derived/albedo-<illumination>-<camera>.exr for every subject step with a
//    white step under the same illumination and a dark step:
//    (subject − dark) / (white − dark), unscaled by the white target's
//    reflectance (ρ_white is applied by the estimator, which knows the
//    target); pixels where white − dark ≤ 1/1000 of full scale are NaN.
// Each file is recorded in the journal ({"type": "derived", ...}).

#include <filesystem>

#include "chromo/session/journal.hpp"

namespace chromo::session {

void write_derived_data(const std::filesystem::path& folder, Journal& journal, files::StorageBudget* budget);

}  // namespace chromo::session
