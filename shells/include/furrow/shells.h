// furrow::shells — normal-extruded fur shell stacks (Lengyel et al. 2001). The API arrives with issue 4.
#pragma once
#include <furrow/mesh.h>
