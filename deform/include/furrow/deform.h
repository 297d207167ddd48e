// furrow::deform — collider footprints stamped into a heightmap, displaced ground. The API arrives with issue 6.
#pragma once
#include <furrow/mesh.h>
