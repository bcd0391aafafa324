#pragma once
// DeviceError: every failure a driver reports says which device, what it was
// asked and what it answered (DESIGN.md, "Errors").

#include <stdexcept>
#include <string>

namespace chromo::drivers {

class DeviceError : public std::runtime_error {
 public:
  enum class Kind {
    kNotFound,       // no such device / serial / address
    kTimeout,        // the device did not answer in time (it may have gone away)
    kProtocol,       // the answer was malformed, short, oversized or out of sequence
    kRefused,        // the device answered with an error code
    kDisconnected,   // the link is gone (control channel lost, USB unplugged)
    kSaturated,      // a measurement hit full scale
    kFault,          // the device reports a fault (over-temperature, dead channel...)
    kInvalidRequest  // we refused to send it: out of the device's declared limits
  };

  DeviceError(Kind kind, std::string device, std::string request, std::string answer)
      : std::runtime_error(device + ": " + request + ": " + answer),
        kind_(kind),
        device_(std::move(device)),
        request_(std::move(request)),
        answer_(std::move(answer)) {}

  Kind kind() const { return kind_; }
  const std::string& device() const { return device_; }
  const std::string& request() const { return request_; }
  const std::string& answer() const { return answer_; }

 private:
  Kind kind_;
  std::string device_, request_, answer_;
};

}  // namespace chromo::drivers
