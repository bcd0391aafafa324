// journal.jsonl (session/journal.hpp): every line a JSON object, a torn last
// line and malformed lines counted, never thrown.
#include <cstdint>

#include "chromo/session/journal.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = chromo::fuzz::write_input("journal.jsonl", data, size);
  const auto contents = chromo::session::read_journal(path);
  for (const auto& record : contents.records) (void)record.dump();
  return 0;
}
