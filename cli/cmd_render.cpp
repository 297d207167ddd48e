#include "cli_common.h"
namespace furrow::cli {
void register_render(CLI::App&, GlobalFlags&) {}
}
