#pragma once
// IlluminantMean: the illuminant a capture's frames were taken under, the
// mean of each frame's own (Σ applied drive × the LED library's spectrum per
// unit drive, session_captures.hpp).
//
// Where every frame added has the same spectrum bit for bit (the controller
// applied the same levels), mean() is that spectrum exactly: a sum of N equal
// values divided by N is not always the value in floating point. So a
// capture's illuminant from its white reference alone equals, bit for bit,
// the one from the white and the subject together, and the tables chromod
// prepares from the references during capture are the ones the estimate
// needs (the main job's 4 white frames + 1 subject frame made them differ in
// the last bit and the inverse table was rebuilt after the last frame).
//
// Thread rules: a value type; no shared state.

#include "chromo/spectral/spectrum.hpp"

namespace chromo::session {

class IlluminantMean {
 public:
  void add(const spectral::Spectrum& frame_illuminant) {
    if (frames_ == 0) first_ = frame_illuminant;
    else uniform_ = uniform_ && (frame_illuminant.values() == first_.values()).all();
    sum_ += frame_illuminant;
    ++frames_;
  }
  // Both sets of frames together (a white and its subject).
  IlluminantMean& operator+=(const IlluminantMean& other) {
    if (other.frames_ == 0) return *this;
    if (frames_ == 0) return *this = other;
    uniform_ = uniform_ && other.uniform_ && (other.first_.values() == first_.values()).all();
    sum_ += other.sum_;
    frames_ += other.frames_;
    return *this;
  }
  unsigned frames() const { return frames_; }
  // The frames' mean illuminant: exactly the frames' one spectrum where they
  // share it; zero without frames.
  spectral::Spectrum mean() const {
    if (frames_ == 0) return {};
    return uniform_ ? first_ : sum_ / static_cast<double>(frames_);
  }

 private:
  spectral::Spectrum sum_, first_;
  unsigned frames_ = 0;
  bool uniform_ = true;
};

}  // namespace chromo::session
