#include "luz/core/version.h"

#include "luz/version_commit.h"

namespace luz {

const char* version() { return LUZ_VERSION; }
const char* commit() { return LUZ_COMMIT; }

}  // namespace luz
