// CLI11 for the benches, its own code compiled without optimisation.
//
// Debian's CLI11 (2.1.2) is header-only, without the precompiled mode of
// later versions, so every bench's translation unit compiles the parser
// again: 19.4 s of CPU for a three-option program at -O3, 10.8 s with
// CLI11's functions at -O0 (7 Dec, load ~6; a bench's whole unity file is
// 30-55 s, tests/README.md "CI time"). A bench parses its command line once,
// so nothing it times runs this code.
//
// The standard headers CLI11 includes come first, at the build's own
// optimisation: a header first included inside the pragma would carry -O0
// into the bench's own use of it (include guards stop the second inclusion).
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <iterator>
#include <limits>
#include <locale>
#include <map>
#include <memory>
#include <numeric>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <sys/stat.h>
#include <sys/types.h>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#pragma GCC push_options
#pragma GCC optimize("O0")
#include <CLI/CLI.hpp>
#pragma GCC pop_options
