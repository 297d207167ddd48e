#include "cli_common.h"
namespace furrow::cli {
void register_convert(CLI::App&, GlobalFlags&) {}
}
