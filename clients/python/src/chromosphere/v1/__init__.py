"""Generated gRPC and protobuf stubs of chromod's API (proto/), filled at build time."""
