// chromo export: a stored session's maps (and, with --frames, its raw frames)
// in the formats researchers open: OME-TIFF for Fiji, napari and Python
// (maps/ome_tiff.hpp), or a copy of maps.exr. Everything is checked before
// anything is written; each file is written durably (temporary, fsync,
// rename), so bad input changes nothing.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>

#include <filesystem>
#include <map>
#include <memory>

#include "chromo/files/durable_file.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/maps/ome_tiff.hpp"
#include "chromo/session/session_store.hpp"
#include "commands.hpp"

namespace chromo::cli {

namespace fs = std::filesystem;

namespace {

struct ExportOptions {
  fs::path input;
  std::string format = "ome-tiff";
  fs::path out;
  bool frames = false;
  double pixel_size_um = 0;
  int threads = 0;
};

// The folders holding a maps.exr: the input itself (a `chromo estimate --out`
// folder), a session's results/, or one results/<camera>/ per camera.
std::vector<fs::path> map_folders(const fs::path& input) {
  if (fs::is_regular_file(input / "maps.exr")) return {input};
  std::vector<fs::path> folders;
  const fs::path results = input / "results";
  if (fs::is_regular_file(results / "maps.exr")) folders.push_back(results);
  if (fs::is_directory(results))
    for (const auto& entry : fs::directory_iterator(results))
      if (entry.is_directory() && fs::is_regular_file(entry.path() / "maps.exr")) folders.push_back(entry.path());
  std::sort(folders.begin(), folders.end());
  return folders;
}

int run_export(const ExportOptions& o) {
  if (!fs::is_directory(o.input)) throw std::invalid_argument(o.input.string() + ": not a directory");
  if (!(o.pixel_size_um >= 0) || !std::isfinite(o.pixel_size_um))
    throw std::invalid_argument("--pixel-size-um: " + fmt::format("{}", o.pixel_size_um) + " is not > 0 (or 0: unknown)");
  if (o.threads < 0) throw std::invalid_argument("--threads: " + std::to_string(o.threads) + " is below 0 (0: all cores)");
  if (o.format == "exr" && o.out.empty())
    throw std::invalid_argument("--format exr: maps.exr is already in the session; give --out DIR to copy it");
  const std::vector<fs::path> folders = map_folders(o.input);
  if (folders.empty() && !o.frames)
    throw std::invalid_argument(o.input.string() + ": no maps.exr in it, its results/ or results/<camera>/ " +
                                "(estimate them first: chromo estimate SESSION_DIR --out DIR)");
  // Read every input before writing: a bad file changes nothing.
  std::vector<std::pair<fs::path, files::FloatImage>> maps;
  for (const fs::path& folder : folders) {
    const fs::path target = o.out.empty() ? folder : folders.size() == 1 ? o.out : o.out / folder.filename();
    try {
      maps.emplace_back(target, files::read_exr(folder / "maps.exr"));
    } catch (const files::ImageError& e) {
      throw std::invalid_argument(e.what());
    }
  }
  std::map<std::string, std::vector<session::FrameRecord>> frames_of;
  if (o.frames) {
    if (!fs::is_regular_file(o.input / "session.json"))
      throw std::invalid_argument("--frames: " + o.input.string() + " is not a session folder (no session.json)");
    session::SessionInfo info;
    try {
      info = session::SessionStore(o.input.parent_path(), nullptr).read_session(o.input);
    } catch (const std::runtime_error& e) {
      throw std::invalid_argument(std::string("--frames: ") + e.what());
    }
    for (const auto& record : info.frames) frames_of[record.camera].push_back(record);
    if (frames_of.empty()) throw std::invalid_argument("--frames: " + o.input.string() + " has no stored frames");
    for (const auto& [camera, records] : frames_of)
      for (const auto& r : records)
        if (!fs::is_regular_file(o.input / r.file))
          throw std::invalid_argument(fmt::format("--frames: frame {} of camera {}: {} is missing", r.index, camera,
                                                  (o.input / r.file).string()));
  }
  const maps::OmeTiffOptions ome{o.pixel_size_um, o.threads};
  for (const auto& [target, image] : maps) {
    fs::create_directories(target);
    const fs::path file = target / (o.format == "exr" ? "maps.exr" : "maps.ome.tiff");
    files::commit_file_durably(file, nullptr, [&](const fs::path& t) {
      if (o.format == "exr")
        files::write_exr(t, image, {o.threads});
      else
        maps::write_maps_ome_tiff(t, image, ome);
    });
    fmt::print("{}: {}x{}, {} channels ({})\n", file.string(), image.width, image.height, image.channel_names.size(),
               fmt::join(image.channel_names, ", "));
  }
  for (const auto& [camera, records] : frames_of) {
    const fs::path target = o.out.empty() ? o.input / "results" : o.out;
    fs::create_directories(target);
    const fs::path file = target / ("frames-" + camera + ".ome.tiff");
    files::commit_file_durably(file, nullptr,
                               [&](const fs::path& t) { maps::write_frames_ome_tiff(t, o.input, records, ome); });
    fmt::print("{}: {} frames of camera {}\n", file.string(), records.size(), camera);
  }
  return kExitOk;
}

}  // namespace

void add_export_command(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<ExportOptions>();
  CLI::App* cmd = app.add_subcommand(
      "export", "A stored session's maps as OME-TIFF (Fiji, napari, Python) or EXR; --frames: its raw frames as OME-TIFF");
  cmd->add_option("session", options->input, "session folder (or a chromo estimate --out folder)")->required();
  cmd->add_option("--format", options->format, "ome-tiff (maps.ome.tiff) or exr (a copy of maps.exr, needs --out)")
      ->check(CLI::IsMember({"ome-tiff", "exr"}))
      ->capture_default_str();
  cmd->add_option("--out", options->out, "output folder (default: beside each maps.exr; frames into results/)");
  cmd->add_flag("--frames", options->frames, "also the raw frames, one OME-TIFF stack per camera");
  cmd->add_option("--pixel-size-um", options->pixel_size_um, "pixel size on the subject in µm (OME PhysicalSizeX/Y)");
  cmd->add_option("--threads", options->threads, "compression threads (0 = all cores)");
  cmd->callback([options, &exit_status] { exit_status = run_map_operation("export", [&] { run_export(*options); }); });
}

}  // namespace chromo::cli
