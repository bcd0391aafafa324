#!/usr/bin/python3
"""A gRPC client that knows nothing of the server it talks to: it learns the
services, methods and message types through gRPC server reflection, and
calls any unary method with a JSON request, printing the JSON answer.

    reflection_client.py TARGET list
    reflection_client.py TARGET describe SERVICE
    reflection_client.py TARGET call SERVICE/METHOD [JSON]

TARGET is a gRPC address (unix:/run/chromosphere/chromod.sock, host:port).
The reflection protocol's own messages come from reflection.proto beside
this file, compiled with protoc at start into a temporary folder (Debian has
no grpcio-reflection). Exit status: 0 done, 1 the call failed (its gRPC
status on stderr), 2 bad command line or an unknown service or method.
"""
import json
import os
import subprocess
import sys
import tempfile

import grpc
from google.protobuf import descriptor_pb2, descriptor_pool, json_format, message_factory

REFLECTION = "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo"


def reflection_messages():
    """The reflection protocol's message classes, from reflection.proto via protoc."""
    here = os.path.dirname(os.path.abspath(__file__))
    out = tempfile.mkdtemp(prefix="reflection-pb2-")
    subprocess.run(["protoc", f"-I{here}", f"--python_out={out}", "reflection.proto"], check=True)
    sys.path.insert(0, out)
    import reflection_pb2  # noqa: E402 (generated just above)
    return reflection_pb2


class ReflectionClient:
    """Services and message types of a server, learnt through reflection."""

    def __init__(self, target):
        self.channel = grpc.insecure_channel(target)
        self.pb = reflection_messages()
        self.pool = descriptor_pool.DescriptorPool()
        self.added = set()
        self.stream = self.channel.stream_stream(
            REFLECTION,
            request_serializer=self.pb.ServerReflectionRequest.SerializeToString,
            response_deserializer=self.pb.ServerReflectionResponse.FromString)

    def ask(self, **request):
        """One request on a reflection stream; its response (errors raise)."""
        responses = self.stream(iter([self.pb.ServerReflectionRequest(**request)]), timeout=30)
        response = next(iter(responses))
        if response.HasField("error_response"):
            raise LookupError(f"{request}: {response.error_response.error_message} "
                              f"(code {response.error_response.error_code})")
        return response

    def services(self):
        return sorted(s.name for s in self.ask(list_services="").list_services_response.service)

    def load(self, symbol):
        """The files declaring `symbol`, added to the pool with their dependencies."""
        files = {}
        for data in self.ask(file_containing_symbol=symbol).file_descriptor_response.file_descriptor_proto:
            proto = descriptor_pb2.FileDescriptorProto.FromString(data)
            files[proto.name] = proto

        def add(name):
            if name in self.added or name not in files:
                return
            for dependency in files[name].dependency:
                add(dependency)
            self.pool.Add(files[name])
            self.added.add(name)

        for name in files:
            add(name)
        return self.pool.FindServiceByName(symbol)

    def call(self, service_name, method_name, request_json):
        service = self.load(service_name)
        method = service.methods_by_name.get(method_name)
        if method is None:
            raise LookupError(f"{service_name} has no method {method_name}")
        if method.client_streaming or method.server_streaming:
            raise LookupError(f"{service_name}/{method_name} streams; only unary methods are called")
        factory = message_factory.MessageFactory(self.pool)
        request_class = factory.GetPrototype(method.input_type)
        response_class = factory.GetPrototype(method.output_type)
        request = json_format.Parse(request_json, request_class())
        stub = self.channel.unary_unary(f"/{service_name}/{method_name}",
                                        request_serializer=request_class.SerializeToString,
                                        response_deserializer=response_class.FromString)
        return stub(request, timeout=60)


def main(argv):
    if len(argv) < 3 or argv[2] not in ("list", "describe", "call"):
        print(__doc__, file=sys.stderr)
        return 2
    client = ReflectionClient(argv[1])
    try:
        if argv[2] == "list":
            print("\n".join(client.services()))
        elif argv[2] == "describe" and len(argv) == 4:
            for method in client.load(argv[3]).methods:
                streams = ("stream " if method.client_streaming else "", "stream " if method.server_streaming else "")
                print(f"{method.name}({streams[0]}{method.input_type.full_name}) returns "
                      f"({streams[1]}{method.output_type.full_name})")
        elif argv[2] == "call" and len(argv) in (4, 5) and "/" in argv[3]:
            service, method = argv[3].rsplit("/", 1)
            response = client.call(service, method, argv[4] if len(argv) == 5 else "{}")
            print(json.dumps(json_format.MessageToDict(response), indent=1, sort_keys=True))
        else:
            print(__doc__, file=sys.stderr)
            return 2
    except (LookupError, KeyError, json_format.ParseError) as error:
        print(f"reflection_client: {error}", file=sys.stderr)
        return 2
    except grpc.RpcError as error:
        print(f"reflection_client: {error.code().name}: {error.details()}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
