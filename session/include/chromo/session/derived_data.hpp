#pragma once
// Derived float data of a finished session, from its frame sums
// (frame_sums.hpp): chromod fills them as each frame is stored; a session
// re-processed later fills them from its stored frames (add_stored_frames),
// and the same frames give the same files.
//  - derived/<step>-<camera>-mean.exr: the mean of the step's frames, in
//    units of full scale (0-1), channel "Y" for one-sample formats (Bayer
//    frames stay mosaicked), "R","G","B" for RGB8;
//  - derived/albedo-<illumination>-<camera>.exr for every subject step with a
//    white step under the same illumination and a dark step, by the one
//    definition the estimator uses too (albedo.hpp):
//    ρ_white / g · (subject − dark) / (white − dark), ρ_white = white_reflectance,
//    the white target's known reflectance, g the subject's exposure over its
//    white's (recorded as "exposure_ratio"); pixels where white − dark ≤ 1/1000
//    of full scale are NaN. Per sample as stored (a Bayer mosaic is not
//    binned: the estimator's captures are). (Session format 1 wrote these
//    without ρ_white; before 7 Dec 2026 without g.)
// Each file is recorded in the journal ({"type": "derived", ...}).

#include <filesystem>

#include "chromo/session/frame_sums.hpp"
#include "chromo/session/journal.hpp"
#include "chromo/session/session_plan.hpp"

namespace chromo::session {

// How the files are written: `threads` files at a time, each compressed on
// its worker's thread (0 = one per core; 1 = one after another on the
// caller's thread), ZIP at zip_level (files::ExrWriteOptions; -1 = OpenEXR's
// default). Every setting writes the same pixels; only the bytes of the
// deflate stream depend on the level. background: the files are made on
// worker threads of their own at the lowest CPU priority (nice 19, per
// thread on Linux), so that the process's other work (chromod's maps after
// the last frame) comes first and these take the cores it leaves; the
// caller's thread keeps its priority.
struct DerivedDataOptions {
  int threads = 0;
  int zip_level = -1;
  bool background = false;
};

// Writes into folder/derived/ and appends to `journal` (the records in the
// order above: means by (step, camera), then albedo by plan step). Throws
// std::invalid_argument unless white_reflectance is in (0, 1] and threads
// >= 0; a failed write throws as files::commit_file_durably, after the
// files before it in that order were recorded.
void write_derived_data(const std::filesystem::path& folder, const SessionPlan& plan, const SessionFrameSums& sums,
                        double white_reflectance, Journal& journal, files::StorageBudget* budget,
                        const DerivedDataOptions& options = {});

}  // namespace chromo::session
