#include <algorithm>
#include <cstdlib>
#include <cmath>
#include "web_bridge.hpp"

#include <future>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/util/json_util.h>
#include <grpcpp/generic/generic_stub.h>
#include <nlohmann/json.hpp>

namespace chromo::daemon::web {

namespace {

namespace gp = google::protobuf;

constexpr auto kCallDeadline = std::chrono::minutes(5);  // relighting a large map set takes a while

const char* code_name(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return "OK";
    case grpc::StatusCode::CANCELLED: return "CANCELLED";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS: return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED: return "PERMISSION_DENIED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::UNAUTHENTICATED: return "UNAUTHENTICATED";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::UNIMPLEMENTED: return "UNIMPLEMENTED";
    default: return "INTERNAL";
  }
}

BridgeReply status_reply(const grpc::Status& status) {
  return {http_status_of(status.error_code()), error_json(status.error_message(), code_name(status.error_code()))};
}

// The method and a request message parsed from JSON, or the reply refusing them.
struct Prepared {
  const gp::MethodDescriptor* method = nullptr;
  std::unique_ptr<gp::Message> request;
  std::optional<BridgeReply> refusal;
};

bool is_name(const std::string& text) {
  if (text.empty() || text.size() > 64) return false;
  for (char c : text)
    if (!std::isalnum(static_cast<unsigned char>(c))) return false;
  return true;
}

Prepared prepare(const std::string& service, const std::string& method_name, const std::string& request_json,
                 bool streaming) {
  Prepared prepared;
  if (!is_name(service) || !is_name(method_name)) {
    prepared.refusal = BridgeReply{404, error_json("no such API method", "NOT_FOUND")};
    return prepared;
  }
  const auto* method = gp::DescriptorPool::generated_pool()->FindMethodByName("chromosphere.v1." + service + "." + method_name);
  if (!method) {
    prepared.refusal = BridgeReply{404, error_json("no API method chromosphere.v1." + service + "." + method_name, "NOT_FOUND")};
    return prepared;
  }
  if (method->client_streaming() || method->server_streaming() != streaming) {
    prepared.refusal = BridgeReply{
        400, error_json(service + "." + method_name + (method->server_streaming() ? " streams: use /api/stream/" : " is unary: POST /api/") +
                            service + "/" + method_name,
                        "INVALID_ARGUMENT")};
    return prepared;
  }
  const gp::Message* prototype = gp::MessageFactory::generated_factory()->GetPrototype(method->input_type());
  prepared.request.reset(prototype->New());
  gp::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto parsed = gp::util::JsonStringToMessage(request_json.empty() ? "{}" : request_json, prepared.request.get(), options);
  if (!parsed.ok()) {
    prepared.refusal = BridgeReply{
        400, error_json("request: not a " + method->input_type()->name() + " (" + std::string(parsed.message()) + ")", "INVALID_ARGUMENT")};
    return prepared;
  }
  prepared.method = method;
  return prepared;
}

std::string to_json(const gp::Message& message) {
  gp::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  options.preserve_proto_field_names = true;
  std::string json;
  const auto printed = gp::util::MessageToJsonString(message, &json, options);
  if (!printed.ok()) throw std::runtime_error("response as JSON: " + std::string(printed.message()));
  return json;
}

std::string path_of(const gp::MethodDescriptor& method) {
  return "/" + method.service()->full_name() + "/" + method.name();
}

}  // namespace

int http_status_of(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return 200;
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::OUT_OF_RANGE: return 400;
    case grpc::StatusCode::UNAUTHENTICATED: return 401;
    case grpc::StatusCode::PERMISSION_DENIED: return 403;
    case grpc::StatusCode::NOT_FOUND: return 404;
    case grpc::StatusCode::ALREADY_EXISTS:
    case grpc::StatusCode::FAILED_PRECONDITION:
    case grpc::StatusCode::ABORTED: return 409;
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return 429;
    case grpc::StatusCode::UNIMPLEMENTED: return 501;
    case grpc::StatusCode::UNAVAILABLE: return 503;
    case grpc::StatusCode::DEADLINE_EXCEEDED: return 504;
    default: return 500;
  }
}

std::string error_json(const std::string& message, const std::string& code) {
  return nlohmann::json{{"error", message}, {"code", code}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::optional<std::vector<double>> parse_numbers(const std::string& text, std::size_t count) {
  std::vector<double> numbers;
  std::size_t begin = 0;
  while (begin <= text.size() && numbers.size() <= count) {
    const std::size_t end = std::min(text.find(',', begin), text.size());
    const std::string part = text.substr(begin, end - begin);
    char* parsed_end = nullptr;
    const double value = std::strtod(part.c_str(), &parsed_end);
    if (part.empty() || parsed_end != part.c_str() + part.size() || !std::isfinite(value)) return std::nullopt;
    numbers.push_back(value);
    begin = end + 1;
  }
  if (numbers.size() != count) return std::nullopt;
  return numbers;
}

BridgeReply ApiBridge::call(const std::string& service, const std::string& method_name, const std::string& request_json) const {
  Prepared prepared = prepare(service, method_name, request_json, false);
  if (prepared.refusal) return *prepared.refusal;
  std::string serialized;
  prepared.request->SerializeToString(&serialized);
  grpc::Slice slice(serialized);
  grpc::ByteBuffer request_buffer(&slice, 1), response_buffer;
  grpc::ClientContext context;
  context.AddMetadata("authorization", "Bearer " + token_);
  context.set_deadline(std::chrono::system_clock::now() + kCallDeadline);
  grpc::GenericStub stub(channel_);
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, path_of(*prepared.method), grpc::StubOptions(), &request_buffer, &response_buffer,
                 [&done](grpc::Status status) { done.set_value(std::move(status)); });
  const grpc::Status status = done.get_future().get();
  if (!status.ok()) return status_reply(status);
  std::vector<grpc::Slice> slices;
  if (!response_buffer.Dump(&slices).ok()) return {500, error_json("response: unreadable", "INTERNAL")};
  std::string bytes;
  for (const auto& part : slices) bytes.append(reinterpret_cast<const char*>(part.begin()), part.size());
  std::unique_ptr<gp::Message> response(
      gp::MessageFactory::generated_factory()->GetPrototype(prepared.method->output_type())->New());
  if (!response->ParseFromString(bytes)) return {500, error_json("response: not a " + prepared.method->output_type()->name(), "INTERNAL")};
  return {200, to_json(*response)};
}

BridgeReply ApiBridge::stream(const std::string& service, const std::string& method_name, const std::string& request_json,
                              const std::function<bool(const std::string& json)>& send,
                              std::chrono::milliseconds idle_interval, const std::function<bool()>& idle) const {
  Prepared prepared = prepare(service, method_name, request_json, true);
  if (prepared.refusal) return *prepared.refusal;
  std::string serialized;
  prepared.request->SerializeToString(&serialized);
  grpc::ClientContext context;
  context.AddMetadata("authorization", "Bearer " + token_);
  grpc::GenericStub stub(channel_);
  grpc::CompletionQueue queue;
  void* tag = nullptr;
  bool ok = false;
  auto call = stub.PrepareCall(&context, path_of(*prepared.method), &queue);
  call->StartCall(reinterpret_cast<void*>(1));
  queue.Next(&tag, &ok);
  grpc::Slice slice(serialized);
  grpc::ByteBuffer request_buffer(&slice, 1);
  if (ok) {
    call->Write(request_buffer, reinterpret_cast<void*>(2));
    queue.Next(&tag, &ok);
  }
  if (ok) {
    call->WritesDone(reinterpret_cast<void*>(3));
    queue.Next(&tag, &ok);
  }
  std::unique_ptr<gp::Message> message(
      gp::MessageFactory::generated_factory()->GetPrototype(prepared.method->output_type())->New());
  bool client_left = false;
  while (ok) {
    grpc::ByteBuffer buffer;
    call->Read(&buffer, reinterpret_cast<void*>(4));
    // Waiting for the next message (an idle event stream may wait for hours):
    // the client is asked after each idle_interval whether it is still there.
    bool gone = false;
    while (true) {
      const auto next = queue.AsyncNext(&tag, &ok, std::chrono::system_clock::now() + idle_interval);
      if (next == grpc::CompletionQueue::GOT_EVENT) break;
      if (next == grpc::CompletionQueue::SHUTDOWN) {
        ok = false;
        break;
      }
      if (idle && !idle()) {
        gone = true;
        break;
      }
    }
    if (gone) {
      client_left = true;
      context.TryCancel();
      break;
    }
    if (!ok) break;
    std::vector<grpc::Slice> slices;
    buffer.Dump(&slices);
    std::string bytes;
    for (const auto& part : slices) bytes.append(reinterpret_cast<const char*>(part.begin()), part.size());
    if (!message->ParseFromString(bytes) || !send(to_json(*message))) {
      client_left = true;
      context.TryCancel();
      break;
    }
  }
  grpc::Status status;
  if (client_left) {  // drain the cancelled call's pending read
    call->Finish(&status, reinterpret_cast<void*>(5));
    while (queue.Next(&tag, &ok) && tag != reinterpret_cast<void*>(5)) {
    }
  } else {
    call->Finish(&status, reinterpret_cast<void*>(5));
    queue.Next(&tag, &ok);
  }
  queue.Shutdown();
  while (queue.Next(&tag, &ok)) {
  }
  if (status.ok() || client_left) return {200, ""};
  return status_reply(status);
}

}  // namespace chromo::daemon::web
