#include "cli_common.h"
namespace furrow::cli {
void register_bench(CLI::App&, GlobalFlags&) {}
}
