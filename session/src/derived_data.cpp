#include "chromo/session/derived_data.hpp"
#include "chromo/files/bounded_read.hpp"

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>

#include "chromo/session/frame_files.hpp"
#include "chromo/session/session_plan.hpp"

namespace chromo::session {

namespace {

struct MeanImage {
  int width = 0, height = 0, samples = 1;
  std::vector<double> sum;
  int frames = 0;
  std::vector<float> channel(int c) const {
    std::vector<float> out(static_cast<std::size_t>(width) * height);
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<float>(sum[i * samples + c] / frames);
    return out;
  }
};

void accumulate(MeanImage& mean, const TiffImage& image, double full_scale) {
  if (mean.frames == 0) {
    mean.width = image.width;
    mean.height = image.height;
    mean.samples = image.samples_per_pixel;
    mean.sum.assign(static_cast<std::size_t>(image.width) * image.height * image.samples_per_pixel, 0.0);
  } else if (mean.width != image.width || mean.height != image.height || mean.samples != image.samples_per_pixel) {
    throw std::runtime_error("frames of one step and camera differ in size");
  }
  for (std::size_t i = 0; i < mean.sum.size(); ++i) {
    double value;
    if (image.bits_per_sample == 8) {
      value = image.data[i];
    } else {
      std::uint16_t v;
      std::memcpy(&v, &image.data[i * 2], 2);
      value = v;
    }
    mean.sum[i] += value / full_scale;
  }
  ++mean.frames;
}

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

void write_derived_data(const std::filesystem::path& folder, double white_reflectance, Journal& journal,
                        files::StorageBudget* budget) {
  if (!(white_reflectance > 0 && white_reflectance <= 1))
    throw std::invalid_argument("derived data: white_reflectance must be in (0, 1], not " +
                                std::to_string(white_reflectance));
  const float rho = static_cast<float>(white_reflectance);
  auto session = nlohmann::json::parse(files::read_text_file(folder / "session.json", "JSON"));
  SessionPlan plan = plan_from_json(session.at("plan"));
  std::map<std::pair<std::string, std::string>, MeanImage> means;  // (step, camera)
  for (const auto& record : read_journal(folder / "journal.jsonl").records) {
    if (record.value("type", "") != "frame") continue;
    auto image = read_tiff(folder / record.at("file").get<std::string>());
    const std::string format = record.value("pixel_format", "Mono8");
    const int bits = format.find("12") != std::string::npos ? 12 : image.bits_per_sample;
    accumulate(means[{record.at("step").get<std::string>(), record.at("camera").get<std::string>()}], image,
               std::pow(2.0, bits) - 1);
  }
  std::filesystem::create_directories(folder / "derived");
  auto write = [&](const std::string& name, const MeanImage& like, std::vector<FloatChannel> channels,
                   nlohmann::json extra) {
    write_float_exr(folder / "derived" / name, like.width, like.height, channels, budget);
    extra["type"] = "derived";
    extra["file"] = "derived/" + name;
    journal.append(extra);
  };
  for (const auto& [key, mean] : means) {
    std::vector<FloatChannel> channels;
    auto names = channel_names(mean.samples);
    for (int c = 0; c < mean.samples; ++c) channels.push_back({names[static_cast<std::size_t>(c)], mean.channel(c)});
    write(key.first + "-" + key.second + "-mean.exr", mean, std::move(channels),
          {{"kind", "mean"}, {"step", key.first}, {"camera", key.second}, {"frames", mean.frames}});
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
      if (d == means.end() || w == means.end() || d->second.sum.size() != subject.sum.size() ||
          w->second.sum.size() != subject.sum.size())
        continue;
      std::vector<FloatChannel> channels;
      auto names = channel_names(subject.samples);
      for (int c = 0; c < subject.samples; ++c) {
        auto s = subject.channel(c), dk = d->second.channel(c), wh = w->second.channel(c);
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
