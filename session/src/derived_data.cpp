#include "chromo/session/derived_data.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <map>
#include <thread>

#include <sys/resource.h>
#include <unistd.h>

#include "chromo/files/float_image.hpp"
#include "chromo/session/albedo.hpp"
#include "chromo/session/frame_files.hpp"

namespace chromo::session {

namespace {

std::vector<std::string> channel_names(int samples) {
  return samples == 3 ? std::vector<std::string>{"R", "G", "B"} : std::vector<std::string>{"Y"};
}

std::string illumination_key(const Step& step) {
  switch (step.illumination.kind) {
    case Illumination::Kind::kDark: return "dark";
    case Illumination::Kind::kMix: return step.illumination.mix;
    case Illumination::Kind::kWeights: {
      std::string key = "weights";
      for (double w : step.illumination.weights) {
        key += '_';
        key += std::to_string(static_cast<int>(std::lround(w * 1000)));
      }
      return key;
    }
  }
  return "dark";
}

// One derived file: its channels are made and written by one job (so at
// most `threads` files' pixels are in memory at once); the journal record
// follows once every file is written.
struct DerivedFile {
  std::string name;
  const FrameSums* like;  // its width and height
  std::function<std::vector<FloatChannel>()> channels;
  nlohmann::json record;
};

// derived/<step>-<camera>-mean.exr for every (step, camera) with frames.
void add_mean_files(const SessionFrameSums& sums, std::vector<DerivedFile>& outputs) {
  for (const auto& [key, mean] : sums.by_step_and_camera()) {
    const FrameSums* m = &mean;
    outputs.push_back({key.first + "-" + key.second + "-mean.exr", m,
                       [m] {
                         std::vector<FloatChannel> channels;
                         const int samples = m->format().samples_per_pixel;
                         auto names = channel_names(samples);
                         for (int c = 0; c < samples; ++c)
                           channels.push_back({names[static_cast<std::size_t>(c)], m->mean_channel(c)});
                         return channels;
                       },
                       {{"kind", "mean"}, {"step", key.first}, {"camera", key.second}, {"frames", mean.frames()}}});
  }
}

// The albedo channels of a subject against its white and the dark
// (albedo.hpp: ρ/g·(subject − dark)/(white − dark), g from the subject's and
// the white's exposure; NaN where white − dark ≤ kMinWhiteSignal).
std::vector<FloatChannel> albedo_channels(const FrameSums& subject, const FrameSums& dark, const FrameSums& white,
                                          double white_reflectance) {
  const double rho_over_gain = white_reflectance / subject_exposure_gain(white.exposure_us(), subject.exposure_us());
  std::vector<FloatChannel> channels;
  const int samples = subject.format().samples_per_pixel;
  auto names = channel_names(samples);
  for (int c = 0; c < samples; ++c) {
    auto sv = subject.mean_channel(c), dv = dark.mean_channel(c), wv = white.mean_channel(c);
    std::vector<float> plane(sv.size());
    for (std::size_t i = 0; i < sv.size(); ++i) plane[i] = albedo(sv[i], dv[i], wv[i] - dv[i], rho_over_gain);
    channels.push_back({names[static_cast<std::size_t>(c)], std::move(plane)});
  }
  return channels;
}

// derived/albedo-<illumination>-<camera>.exr per subject step with a white
// under its illumination and a dark step (the plan's first by name), per
// camera that has all three at one size.
void add_albedo_files(const SessionPlan& plan, const SessionFrameSums& sums, double white_reflectance,
                      std::vector<DerivedFile>& outputs) {
  const auto& means = sums.by_step_and_camera();  // (step, camera)
  std::map<std::string, const Step*> dark_steps, white_by_illumination;
  for (const auto& step : plan.steps) {
    if (step.role == StepRole::kDark) dark_steps[step.name] = &step;
    if (step.role == StepRole::kWhite) white_by_illumination[illumination_key(step)] = &step;
  }
  if (dark_steps.empty()) return;
  const std::string dark = dark_steps.begin()->first;
  for (const auto& step : plan.steps) {
    if (step.role != StepRole::kSubject) continue;
    auto white = white_by_illumination.find(illumination_key(step));
    if (white == white_by_illumination.end()) continue;
    for (const auto& [key, subject] : means) {
      if (key.first != step.name) continue;
      auto d = means.find({dark, key.second});
      auto w = means.find({white->second->name, key.second});
      if (d == means.end() || w == means.end() || d->second.sums().size() != subject.sums().size() ||
          w->second.sums().size() != subject.sums().size())
        continue;
      const FrameSums *s = &subject, *dk = &d->second, *wh = &w->second;
      outputs.push_back({"albedo-" + illumination_key(step) + "-" + key.second + ".exr", s,
                         [s, dk, wh, white_reflectance] { return albedo_channels(*s, *dk, *wh, white_reflectance); },
                         {{"kind", "albedo"}, {"step", step.name}, {"camera", key.second},
                          {"white_step", white->second->name}, {"dark_step", dark},
                          {"white_reflectance", white_reflectance},
                          {"exposure_ratio", subject_exposure_gain(wh->exposure_us(), s->exposure_us())}}});
    }
  }
}

// Lowers the calling thread's CPU priority to the lowest (nice 19; Linux
// threads have a priority of their own). Unprivileged it cannot be raised
// again, so only threads made for the work call it. A refusal leaves the
// priority as it was: the files are the same, only sooner.
void lower_this_threads_priority() { setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 19); }

// The files on `threads` workers, each file's blocks compressed on the
// worker's own thread: whole files in parallel need no pool and keep every
// core busy with the channel arithmetic too (in the background every worker
// is a new thread at the lowest priority). Returns each file's failure
// (null where written); no new file is started once one failed.
std::vector<std::exception_ptr> write_files(const std::filesystem::path& folder, const std::vector<DerivedFile>& outputs,
                                            files::StorageBudget* budget, const DerivedDataOptions& options) {
  const int threads = std::min<int>(files::exr_writer_threads(options.threads), static_cast<int>(outputs.size()));
  const files::ExrWriteOptions exr{threads > 1 || options.background ? 1 : files::exr_writer_threads(options.threads), options.zip_level};
  std::vector<std::exception_ptr> failed(outputs.size());
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  auto work = [&] {
    for (std::size_t i = next++; i < outputs.size() && !stop; i = next++) {
      try {
        const DerivedFile& f = outputs[i];
        write_float_exr(folder / "derived" / f.name, f.like->width(), f.like->height(), f.channels(), budget, exr);
      } catch (...) {
        failed[i] = std::current_exception();
        stop = true;
      }
    }
  };
  std::vector<std::thread> workers;
  if (options.background) {
    for (int t = 0; t < threads; ++t) workers.emplace_back([&] {
        lower_this_threads_priority();
        work();
      });
  } else {
    for (int t = 1; t < threads; ++t) workers.emplace_back(work);
    work();
  }
  for (auto& w : workers) w.join();
  return failed;
}

}  // namespace

void write_derived_data(const std::filesystem::path& folder, const SessionPlan& plan, const SessionFrameSums& sums,
                        double white_reflectance, Journal& journal, files::StorageBudget* budget,
                        const DerivedDataOptions& options) {
  if (!(white_reflectance > 0 && white_reflectance <= 1))
    throw std::invalid_argument("derived data: white_reflectance must be in (0, 1], not " +
                                std::to_string(white_reflectance));
  if (options.threads < 0)
    throw std::invalid_argument("derived data: threads must be >= 0, not " + std::to_string(options.threads));
  std::filesystem::create_directories(folder / "derived");
  std::vector<DerivedFile> outputs;
  add_mean_files(sums, outputs);
  add_albedo_files(plan, sums, white_reflectance, outputs);
  const std::vector<std::exception_ptr> failed = write_files(folder, outputs, budget, options);
  // Recorded in order up to the first failure, which is then rethrown (as
  // when the files were written one after another).
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    if (failed[i]) std::rethrow_exception(failed[i]);
    nlohmann::json record = outputs[i].record;
    record["type"] = "derived";
    record["file"] = "derived/" + outputs[i].name;
    journal.append(record);
  }
}

}  // namespace chromo::session
