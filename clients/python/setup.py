"""Builds the package's gRPC stubs from the .proto files at build time.

build_py runs protoc (--python_out, --pyi_out) and Debian's grpc_python_plugin
on ../../proto/chromosphere/v1/*.proto (or $CHROMO_PROTO_DIR) into the build
tree's chromosphere/v1/ (the sources are in src/chromosphere/), so an
installed package carries stubs that match the .proto files it was built from. When no .proto files are found (a copy of the
package without the repository), stubs already present in src/chromosphere/v1/
are shipped as they are; otherwise the build stops naming what is missing.
"""
import os
import shutil
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent


class BuildWithStubs(build_py):
    def run(self):
        super().run()
        out = Path(self.build_lib)
        proto_root = Path(os.environ.get("CHROMO_PROTO_DIR", HERE.parent.parent / "proto"))
        protos = sorted((proto_root / "chromosphere" / "v1").glob("*.proto"))
        target = out / "chromosphere" / "v1"
        target.mkdir(parents=True, exist_ok=True)
        if not protos:
            if list((HERE / "src" / "chromosphere" / "v1").glob("*_pb2.py")):
                return  # shipped stubs, copied by build_py
            raise SystemExit(f"chromosphere: no .proto files in {proto_root}/chromosphere/v1 and no shipped stubs "
                             "(set CHROMO_PROTO_DIR to the repository's proto/ folder)")
        protoc = shutil.which("protoc")
        plugin = shutil.which("grpc_python_plugin")
        if not protoc or not plugin:
            raise SystemExit("chromosphere: protoc and grpc_python_plugin are needed to build the stubs "
                             "(Debian: protobuf-compiler, protobuf-compiler-grpc)")
        command = [protoc, f"-I{proto_root}", f"--python_out={out}", f"--pyi_out={out}",
                   f"--grpc_python_out={out}", f"--plugin=protoc-gen-grpc_python={plugin}"]
        subprocess.run(command + [str(p) for p in protos], check=True)
        (target / "__init__.py").write_text('"""Generated gRPC and protobuf stubs of chromod\'s API (proto/)."""\n')


setup(cmdclass={"build_py": BuildWithStubs})
