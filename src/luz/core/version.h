// Which Luz this is: the release and the source tree's commit.
#pragma once

namespace luz {

const char* version();  // "0.1.0"
const char* commit();   // git describe of the source tree ("1a2b3c4d5e6f", "-dirty" when modified), or "unknown"

}  // namespace luz
