#pragma once

namespace ums {

// "umsvins <version> (<arch>)", for logs and stats.json.
const char* version_string();

}  // namespace ums
