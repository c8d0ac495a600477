// Integrity of ZIP archives (LibTorch's checkpoint files are ZIP archives) before a reader that
// trusts them: LibTorch's importer parses the TorchScript source inside a checkpoint and can crash
// on damaged bytes (found by fuzz_run), and it does not check the CRC-32 the archive stores for
// every entry. A damaged or truncated file fails here with a clear message instead.
#pragma once

#include <string>

namespace mosyn::io {

// Checks that `bytes` is a consistent ZIP archive (central directory and local headers agree)
// whose every entry decompresses to its recorded size and CRC-32. Throws mosyn::Error
// "<name>: ..." naming the first bad entry otherwise.
void check_zip_integrity(const std::string& bytes, const std::string& name);

}  // namespace mosyn::io
