#include "chromo/session/derived_data.hpp"

#include <cmath>
#include <limits>
#include <map>

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

}  // namespace

void write_derived_data(const std::filesystem::path& folder, const SessionPlan& plan, const SessionFrameSums& sums,
                        double white_reflectance, Journal& journal, files::StorageBudget* budget) {
  if (!(white_reflectance > 0 && white_reflectance <= 1))
    throw std::invalid_argument("derived data: white_reflectance must be in (0, 1], not " +
                                std::to_string(white_reflectance));
  const float rho = static_cast<float>(white_reflectance);
  const auto& means = sums.by_step_and_camera();  // (step, camera)
  std::filesystem::create_directories(folder / "derived");
  auto write = [&](const std::string& name, const FrameSums& like, std::vector<FloatChannel> channels,
                   nlohmann::json extra) {
    write_float_exr(folder / "derived" / name, like.width(), like.height(), channels, budget);
    extra["type"] = "derived";
    extra["file"] = "derived/" + name;
    journal.append(extra);
  };
  for (const auto& [key, mean] : means) {
    std::vector<FloatChannel> channels;
    const int samples = mean.format().samples_per_pixel;
    auto names = channel_names(samples);
    for (int c = 0; c < samples; ++c) channels.push_back({names[static_cast<std::size_t>(c)], mean.mean_channel(c)});
    write(key.first + "-" + key.second + "-mean.exr", mean, std::move(channels),
          {{"kind", "mean"}, {"step", key.first}, {"camera", key.second}, {"frames", mean.frames()}});
  }
  // Albedo per subject step.
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
      std::vector<FloatChannel> channels;
      const int samples = subject.format().samples_per_pixel;
      auto names = channel_names(samples);
      for (int c = 0; c < samples; ++c) {
        auto s = subject.mean_channel(c), dk = d->second.mean_channel(c), wh = w->second.mean_channel(c);
        std::vector<float> albedo(s.size());
        for (std::size_t i = 0; i < s.size(); ++i) {
          float denominator = wh[i] - dk[i];
          albedo[i] = denominator > 1e-3f ? rho * (s[i] - dk[i]) / denominator : std::numeric_limits<float>::quiet_NaN();
        }
        channels.push_back({names[static_cast<std::size_t>(c)], std::move(albedo)});
      }
      write("albedo-" + illumination_key(step) + "-" + key.second + ".exr", subject, std::move(channels),
            {{"kind", "albedo"}, {"step", step.name}, {"camera", key.second}, {"white_step", white->second->name},
             {"dark_step", dark}, {"white_reflectance", white_reflectance}});
    }
  }
}

}  // namespace chromo::session
