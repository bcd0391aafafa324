// CameraService: the cameras, the live view's exposure and pixel format, and
// the preview stream (cameras.proto; preview_hub.hpp, preview_image.hpp).
#include <chrono>
#include <string>

#include "chromo/daemon/internal/capture/preview_image.hpp"
#include "chromosphere/v1/cameras.grpc.pb.h"
#include "services.hpp"

namespace chromo::daemon::services {
namespace {

constexpr double kMaxPreviewRateHz = 30;
constexpr double kDefaultPreviewRateHz = 10;
constexpr int kDefaultPreviewWidth = 480;

class CameraServiceImpl final : public pb::CameraService::Service {
 public:
  CameraServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}

  Status ListCameras(ServerContext* context, const pb::ListCamerasRequest*, pb::ListCamerasResponse* response) override {
    return guard_(context, [&] {
      for (auto& camera : daemon_.devices().cameras) describe(*camera, response->add_cameras());
      return Status::OK;
    });
  }

  Status SetCameraSettings(ServerContext* context, const pb::SetCameraSettingsRequest* request,
                           pb::CameraDescription* response) override {
    return guard_.audited(context, "set_camera_settings", [&](nlohmann::json& details) {
      details["camera"] = request->camera();
      if (Status s = check_device_name("camera", request->camera()); !s.ok()) return s;
      auto& camera = daemon_.previews().camera(request->camera());
      LiveSettings settings = daemon_.previews().settings(camera.config.name);
      drivers::CameraInfo info;
      {
        std::lock_guard lock(camera.mutex);
        if (!camera.device) return Status(StatusCode::UNAVAILABLE, camera.config.name + ": " + camera.open_error);
        info = camera.device->info();
      }
      if (request->has_exposure_us()) {
        const double exposure_us = request->exposure_us();
        details["exposure_us"] = exposure_us;
        const double low = info.exposure_min_us > 0 ? info.exposure_min_us : 1;
        const double high = info.exposure_max_us > 0 ? info.exposure_max_us : 10e6;
        if (!(exposure_us >= low && exposure_us <= high))
          return invalid("exposure_us: " + std::to_string(exposure_us) + " is outside the camera's [" +
                         std::to_string(low) + ", " + std::to_string(high) + "] µs");
        settings.exposure_us = exposure_us;
      }
      if (!request->pixel_format().empty()) {
        details["pixel_format"] = request->pixel_format();
        const auto format = drivers::parse_pixel_format(request->pixel_format());
        if (!format) return invalid("pixel_format: \"" + request->pixel_format() + "\" is not one of " + drivers::pixel_format_names());
        if (!info.pixel_formats.empty() &&
            std::find(info.pixel_formats.begin(), info.pixel_formats.end(), *format) == info.pixel_formats.end())
          return invalid("pixel_format: camera \"" + camera.config.name + "\" does not offer " + request->pixel_format());
        settings.pixel_format = *format;
      }
      daemon_.previews().set_settings(camera.config.name, settings);
      describe(camera, response);
      return Status::OK;
    });
  }

  Status StreamPreview(ServerContext* context, const pb::StreamPreviewRequest* request,
                       grpc::ServerWriter<pb::PreviewFrame>* writer) override {
    return guard_.stream(context, [&] {
      if (Status s = check_device_name("camera", request->camera()); !s.ok()) return s;
      const double rate_hz = request->rate_hz() == 0 ? kDefaultPreviewRateHz : request->rate_hz();
      if (!(rate_hz > 0 && rate_hz <= kMaxPreviewRateHz))
        return invalid("rate_hz: must be in (0, " + std::to_string(static_cast<int>(kMaxPreviewRateHz)) + "]");
      const int width = request->width() == 0 ? kDefaultPreviewWidth : static_cast<int>(request->width());
      if (width < kMinPreviewWidth || width > kMaxPreviewWidth)
        return invalid("width: must be in [" + std::to_string(kMinPreviewWidth) + ", " + std::to_string(kMaxPreviewWidth) + "]");
      PreviewOptions options;
      options.width = width;
      if (request->has_region() && (request->region().width() != 0 || request->region().height() != 0)) {
        const auto& r = request->region();
        options.region = {r.x(), r.y(), r.width(), r.height()};
        if (!(r.x() >= 0 && r.y() >= 0 && r.width() > 0 && r.height() > 0 && r.x() + r.width() <= 1 && r.y() + r.height() <= 1))
          return invalid("region: must lie inside the frame, in fractions of it (x, y >= 0; width, height > 0; x + width, y + height <= 1)");
      }
      const std::string name = daemon_.previews().camera(request->camera()).config.name;
      PreviewHub::Watch watch(daemon_.previews(), name, rate_hz);
      const auto interval = std::chrono::duration<double>(1.0 / rate_hz);
      auto sent_at = std::chrono::steady_clock::time_point{};
      // The white balance follows the LEDs: computed again every second.
      WhiteBalance balance;
      if (!request->white_balance()) balance.description = "none: raw (not asked)";
      auto balanced_at = std::chrono::steady_clock::time_point{};
      while (!context->IsCancelled() && !guard_.stopping()) {
        auto kept = watch.next(std::chrono::milliseconds(200));
        if (!kept) continue;
        const auto now = std::chrono::steady_clock::now();
        if (now - sent_at < interval * 0.9) continue;  // a faster watcher's frame
        sent_at = now;
        const auto& frame = kept->frame;
        const bool colour = drivers::pixel_format_info(frame.pixel_format).layout != drivers::ColourLayout::kMono;
        if (request->white_balance() && now - balanced_at > std::chrono::seconds(1)) {
          balance = colour ? daemon_.preview_white_balance(name) : WhiteBalance{{1, 1, 1}, "none: raw (mono camera)"};
          balanced_at = now;
        }
        options.white_balance_gains = balance.gains;
        const PreviewImage image = make_preview(frame.width, frame.height, frame.pixel_format, frame.data, options);
        pb::PreviewFrame message;
        message.set_camera(name);
        message.set_width(static_cast<std::uint32_t>(image.width));
        message.set_height(static_cast<std::uint32_t>(image.height));
        message.set_jpeg(image.jpeg.data(), image.jpeg.size());
        message.set_clipped_mask(image.clipped_mask.data(), image.clipped_mask.size());
        message.set_clipped_pixels(image.clipped_pixels);
        for (auto count : image.histogram) message.add_histogram(count);
        message.set_full_scale(image.full_scale);
        message.set_pixel_format(std::string(drivers::pixel_format_name(frame.pixel_format)));
        message.set_exposure_us(kept->exposure_us);
        message.set_source(kept->source);
        message.set_sequence(frame.sequence);
        message.set_time_ms(std::chrono::duration_cast<std::chrono::milliseconds>(frame.host_timestamp.time_since_epoch()).count());
        message.set_source_width(frame.width);
        message.set_source_height(frame.height);
        for (double mean : image.region_mean) message.add_region_mean(mean);
        message.set_region_cells(image.region_cells);
        message.set_region_x(image.region_x), message.set_region_y(image.region_y);
        message.set_region_width(image.region_width), message.set_region_height(image.region_height);
        message.set_white_balance(balance.description);
        for (double gain : balance.gains) message.add_white_balance_gains(gain);
        if (!writer->Write(message)) break;
      }
      return Status::OK;
    });
  }

 private:
  void describe(NamedDevice<drivers::Camera>& camera, pb::CameraDescription* out) {
    out->set_name(camera.config.name);
    const LiveSettings live = daemon_.previews().settings(camera.config.name);
    out->set_pixel_format(std::string(drivers::pixel_format_name(live.pixel_format)));
    out->set_exposure_us(live.exposure_us);
    std::lock_guard lock(camera.mutex);
    if (!camera.device) {
      out->set_error(camera.open_error);
      return;
    }
    try {
      const auto info = camera.device->info();
      out->set_vendor(info.vendor), out->set_model(info.model), out->set_serial(info.serial);
      out->set_sensor_width(info.sensor_width), out->set_sensor_height(info.sensor_height);
      for (auto format : info.pixel_formats) out->add_pixel_formats(std::string(drivers::pixel_format_name(format)));
      out->set_exposure_min_us(info.exposure_min_us), out->set_exposure_max_us(info.exposure_max_us);
      const drivers::StreamStatistics statistics = camera.device->statistics();
      auto* stream = out->mutable_stream();
      stream->set_completed(statistics.completed), stream->set_failed(statistics.failed);
      stream->set_lost_before_driver(statistics.lost_before_driver);
      stream->set_resend_requests(statistics.resend_requests), stream->set_resent_packets(statistics.resent_packets);
      stream->set_missing_packets(statistics.missing_packets), stream->set_reconnects(statistics.reconnects);
    } catch (const std::exception& error) {
      out->set_error(error.what());
    }
  }

  Daemon& daemon_;
  Guard& guard_;
};

}  // namespace

std::unique_ptr<grpc::Service> make_camera_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<CameraServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
