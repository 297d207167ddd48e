#include "cli_common.h"
namespace furrow::cli {
void register_demo(CLI::App&, GlobalFlags&) {}
}
