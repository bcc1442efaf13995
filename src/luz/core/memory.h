// The memory a render may still take, and the check that refuses work which
// would not fit before it is allocated (a reader's arrays from a header's
// counts, the films, the acceleration structure): one line naming what
// needs how much and what is available, rather than the kernel's OOM killer
// or a std::bad_alloc midway.
#pragma once

#include <cstdint>
#include <string>

namespace luz {

// Bytes this process could still allocate: the least of the kernel's
// MemAvailable, its cgroup's limit less its usage (v2 or v1), and the
// headroom under RLIMIT_AS and RLIMIT_DATA (ulimit -v, -d). 0 when none is known.
uint64_t available_memory();

// "12.3 GiB" (one decimal), or "512 MiB" below one GiB.
std::string memory_text(uint64_t bytes);

// Throws InputError(file, line, what + " need N of memory; M are available")
// when `bytes` and 128 MiB to spare exceed available_memory(). Cheap for small requests: the
// limits are read only once requests since the last reading add up to 16 MiB
// (what was allocated before is resident, so the reading accounts for it).
void require_memory(uint64_t bytes, const std::string& file, const std::string& what, int line = 0);

}  // namespace luz
