#pragma once
// Registration of the captures of one subject (the subject moves between the
// broadband and the W57+blue captures): OpenCV's ECC (cv::findTransformECC,
// Euclidean motion: shift + rotation) on one channel the two images share,
// then a warp of every channel of the moving image onto the reference.
//
// Residual motion: after warping, ECC is run once more between the reference
// and the warped image; the largest displacement that remaining transform
// gives any image corner is reported (pixels). A coarse pyramid level where
// ECC does not converge is skipped (listed in skipped_levels; the next finer
// level starts from the warp so far); when the finest level does not
// converge, RegistrationError names what failed and nothing is warped.
//
// Thread rules: free functions, reentrant (OpenCV may use its own threads).

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace chromo::session {

class RegistrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct RegistrationOptions {
  int max_iterations = 200;
  double epsilon = 1e-6;
  int pyramid_levels = 3;  // coarse-to-fine: handles shifts of tens of pixels
};

struct RegistrationResult {
  double shift_x_px = 0, shift_y_px = 0;  // moving → reference
  double rotation_deg = 0;
  double correlation = 0;                 // ECC's enhanced correlation at the end
  double residual_motion_px = 0;          // see above
  double warp[2][3] = {{1, 0, 0}, {0, 1, 0}};
  std::uint32_t skipped_levels = 0;       // bit l set: coarse pyramid level l (> 0) did not converge, skipped
};

// reference_channel, moving_channel: width × height floats (row-major).
RegistrationResult estimate_registration(const std::vector<float>& reference_channel,
                                         const std::vector<float>& moving_channel, int width, int height,
                                         const RegistrationOptions& options = {});

// Warps one channel of the moving image onto the reference's pixel grid
// (bilinear; pixels that fall outside are NaN, so the estimator flags them).
std::vector<float> warp_channel(const std::vector<float>& moving_channel, int width, int height,
                                const RegistrationResult& registration);

// Registration then the residual check on the warped image.
RegistrationResult register_channel(const std::vector<float>& reference_channel,
                                    const std::vector<float>& moving_channel, int width, int height,
                                    const RegistrationOptions& options = {});

// Largest displacement the registration's transform gives an image corner.
double corner_displacement_px(const RegistrationResult& registration, int width, int height);

// A capture whose registration moves no image corner by more than this is not
// warped: that motion is registration noise, and a warp would only blur.
inline constexpr double kWarpThresholdPx = 0.1;

// One capture registered to the reference, as summary.json reports it.
struct RegistrationReport {
  std::string image, reference, channel;
  RegistrationResult result;
  double motion_px = 0;  // corner_displacement_px of the found transform
  bool warped = false;   // motion_px > kWarpThresholdPx: the capture was warped onto the reference
};

}  // namespace chromo::session
