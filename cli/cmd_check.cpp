#include "cli_common.h"
namespace furrow::cli {
void register_check(CLI::App&, GlobalFlags&) {}
}
