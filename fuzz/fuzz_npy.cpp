// libFuzzer harness: NPY bytes (io/npy.h). An array that parses must hold as many elements as
// its shape says and write back to bytes that parse to the same array.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "fuzz_check.h"
#include "io/npy.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mosyn;
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  io::NpyArray array;
  try {
    array = io::parse_npy(bytes, "fuzz.npy");
  } catch (const Error&) {
    return 0;
  }
  FUZZ_CHECK(array.bytes.size() == static_cast<size_t>(array.num_elements()) * io::element_size(array.dtype));
  FUZZ_CHECK(array.to_float64().size() == static_cast<size_t>(array.num_elements()));
  const io::NpyArray again = io::parse_npy(io::format_npy(array), "again.npy");
  FUZZ_CHECK(again.shape == array.shape);
  FUZZ_CHECK(again.dtype == array.dtype);
  FUZZ_CHECK(again.bytes == array.bytes);
  return 0;
}
