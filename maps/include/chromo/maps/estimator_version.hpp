#pragma once
// The estimator's version as sessions, reports and studies record it.
#include <string>

namespace chromo::maps {

// "chromosphere <version>; model+tables <16 hex>": the project's version and
// the forward table's cache key of a fixed probe measurement set, which
// changes with the skin model's code or data and the table's format.
// Computed once per process (a table key, no table is built).
std::string estimator_version();

}  // namespace chromo::maps
