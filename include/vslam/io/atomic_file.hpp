#pragma once
// Output files that appear complete or not at all: written under a temporary
// name in the same folder, then renamed over the final name (an atomic step on
// one file system), so a crash, a full disk or a kill never leaves a
// half-written trajectory or report behind.
#include <functional>
#include <string>

namespace vslam {

// Calls `write` with the temporary path (".<name>.partial" beside `path`), then
// renames it to `path`. If `write` throws or the rename fails, the temporary
// file is removed and the error, naming `path`, is thrown as InputError (an
// exception of `write` is rethrown as it is).
void writeFileAtomically(const std::string& path, const std::function<void(const std::string& temporary)>& write);

}  // namespace vslam
