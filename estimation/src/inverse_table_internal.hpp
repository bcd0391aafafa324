#pragma once
// Internal to estimation/: what inverse_table.cpp (settings, key space, cache
// file) and inverse_table_build.cpp (the build) share: the cache file's
// format and the build's settings (all part of the cache key).

#include <cstdint>

#include "chromo/files/binary_cache.hpp"

namespace chromo::estimation::detail {

// Version 7: the key space of any channel count (channel count, captured
// variance, per-channel whitening and mean, key_dims × channels axes).
// Version 6: the file is a files/binary_cache.hpp file (its checksum and the
// key hash are the one byte-wise Fnv1a; version 5 hashed 8-byte words).
inline constexpr files::CacheFormat kCacheFormat{{'C', 'H', 'R', 'O', 'M', 'O', 'I', 'T'}, 7};
// Build settings (part of the cache key).
inline constexpr int kMaxSeedsPerCell = 12;     // LM solves per cell, best groups first
inline constexpr int kBranchIterations = 40;    // LM iterations per solve
inline constexpr double kSameBranch = 0.25;     // solutions closer than this (node units) are one branch
inline constexpr double kBranchChi2Margin = 1;  // keep branches with χ² ≤ best + this (σ = 1% of the value)
inline constexpr double kMaxCondition = 1e4;    // pseudo-inverse: singular values below σ_max / this dropped
// Fill reach (bins) per key axis, widest axis first: about three times the
// camera noise (σ ≈ 2% at albedo 0.3) in bins of that axis.
inline constexpr int kFillReach[4] = {2, 4, 16, 48};
// Empty cells within the fill reach get their own pre-solved branch, one per
// block of kPresolveBlock[a] bins along key axis a (widest axis first): the
// bounded fit at the block centre's measurement (see presolve_empty_cells).
// Measured on the lab session (estimation.md): blocks of 1×1×2×4 bins cost
// 87 MB and 3-5 s of build for the same fit time; 2×2×8×16 leave more noisy
// pixels to Gauss-Newton and the search.
inline constexpr int kPresolveBlock[4] = {1, 1, 4, 8};

}  // namespace chromo::estimation::detail
