#pragma once
// A self-signed certificate for localhost made by the openssl command line
// (Debian's openssl): the TLS tests of the gRPC port and the web view.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace chromo::testing {

struct TestCertificate {
  std::filesystem::path key_file, certificate_file;
  std::string certificate_pem;  // what a client trusts
};

// Writes key.pem and cert.pem (valid one day, CN and SAN localhost) into
// `directory`; throws std::runtime_error when openssl fails.
inline TestCertificate make_test_certificate(const std::filesystem::path& directory) {
  TestCertificate made{directory / "key.pem", directory / "cert.pem", {}};
  const std::string command = "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost "
                              "-addext subjectAltName=DNS:localhost -keyout " + made.key_file.string() + " -out " +
                              made.certificate_file.string() + " >/dev/null 2>&1";
  if (std::system(command.c_str()) != 0) throw std::runtime_error("openssl could not make a test certificate");
  std::ifstream in(made.certificate_file);
  std::stringstream pem;
  pem << in.rdbuf();
  made.certificate_pem = pem.str();
  return made;
}

}  // namespace chromo::testing
