// The committed sample session folder in format 1 (data/test/session-format-1).
#pragma once

#include <filesystem>

namespace chromo::testing {
inline const std::filesystem::path kSessionFormatOneSample =
    std::filesystem::path(CHROMO_TEST_DATA_DIR) / "session-format-1";
}  // namespace chromo::testing
