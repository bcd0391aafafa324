// CalibrationService: the mix solver on the daemon's LED library and calibration runs (calibration.proto).
#include <string>

#include "chromo/calibration/led_library.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/grid.hpp"
#include "chromosphere/v1/calibration.grpc.pb.h"
#include "services.hpp"

namespace chromo::daemon::services {
namespace {

class CalibrationServiceImpl final : public pb::CalibrationService::Service {
 public:
  CalibrationServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}
  Status SolveMix(ServerContext* context, const pb::SolveMixRequest* request, pb::SolveMixResponse* response) override {
    return guard_(context, [&] {
      if (request->target().size() > 256) return invalid("target: longer than 256 bytes");
      if (!pb::MixObjective_IsValid(request->objective())) return invalid("objective: unknown value");
      std::string objective = "camera";
      if (request->objective() == pb::MIX_OBJECTIVE_SPECTRAL) objective = "spectral";
      if (request->objective() == pb::MIX_OBJECTIVE_XYZ) objective = "xyz";
      const bool w57 = request->target() == "w57";
      if (!w57 && (request->target().ends_with(".csv") || request->target().find('/') != std::string::npos))
        return invalid("target: files are not accepted over the API (d65, w57, w57+blue[:R], cct:K)");
      // The calibration library's mix solver on the daemon's LED library
      // (calibrations.hpp); FAILED_PRECONDITION when there is none yet.
      auto solved = daemon_.calibrations().solve(request->target(), objective, request->hold_chromaticity());
      to_proto(solved.weights, response->mutable_weights());
      for (const auto& [name, value] : solved.figures) (*response->mutable_figures())[name] = value;
      response->set_summary(solved.summary);
      response->set_library(solved.library);
      return Status::OK;
    });
  }
  Status StartCalibration(ServerContext* context, const pb::StartCalibrationRequest* request,
                          pb::Operation* response) override {
    return guard_.audited(context, "start_calibration", [&](nlohmann::json&) {
      if (request->drive_levels_size() > 64) return invalid("drive_levels: at most 64 rungs");
      if (request->controller().size() > 64) return invalid("controller: longer than 64 bytes");
      if (request->spectrometer().size() > 64) return invalid("spectrometer: longer than 64 bytes");
      CalibrationRequest calibration;
      calibration.controller = request->controller();
      calibration.spectrometer = request->spectrometer();
      calibration.drive_levels.assign(request->drive_levels().begin(), request->drive_levels().end());
      calibration.warmup_ms = request->warmup_ms();
      // Field-naming std::invalid_argument → INVALID_ARGUMENT; another
      // operation running or no reference lamp → FAILED_PRECONDITION.
      to_proto(daemon_.start_calibration(calibration), response);
      return Status::OK;
    });
  }

  Status AdoptCalibration(ServerContext* context, const pb::AdoptCalibrationRequest* request,
                          pb::AdoptCalibrationResponse* response) override {
    return guard_.audited(context, "adopt_calibration", [&](nlohmann::json& details) {
      if (Status s = check_id("id", request->id()); !s.ok()) return s;
      if (request->reason().size() > 1024) return invalid("reason: longer than 1024 bytes");
      if (auto bad = session::control_character_error(request->reason()); !bad.empty()) return invalid("reason: " + bad);
      details["calibration"] = request->id();
      details["reason"] = request->reason();
      response->set_library(daemon_.adopt_calibration(request->id(), request->reason()));
      return Status::OK;
    });
  }

  Status GetLedLibrary(ServerContext* context, const pb::GetLedLibraryRequest*, pb::GetLedLibraryResponse* response) override {
    return guard_(context, [&] {
      const auto library = daemon_.calibrations().library();
      if (!library) throw std::logic_error("no LED library: run a calibration (chromo calibrate) or configure led_library");
      response->set_library(daemon_.calibrations().library_path());
      response->set_source(library->source);
      response->set_created_utc(library->created_utc);
      for (int i = 0; i < spectral::kGridSize; ++i) response->add_wavelength_nm(spectral::grid_wavelength_nm(i));
      for (double value : spectral::illuminant_d65().values()) response->add_d65(value);
      for (const auto& record : library->leds) {
        auto* led = response->add_leds();
        led->set_led(std::string(spectral::led_type_name(record.type)));
        led->set_description(record.description);
        led->set_max_drive_level(record.max_drive_level);
        for (const auto& rung : record.ladder) led->add_drive_levels(rung.drive_level);
        for (double value : record.spectrum_per_unit_drive().values()) led->add_spectrum_per_unit_drive(value);
      }
      return Status::OK;
    });
  }

 private:
  Daemon& daemon_;
  Guard& guard_;
};

}  // namespace

std::unique_ptr<grpc::Service> make_calibration_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<CalibrationServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
