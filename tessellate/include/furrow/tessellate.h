// furrow::tessellate — adaptive, crack-free tessellation with OpenSubdiv Bfr. The API arrives with issue 5.
#pragma once
#include <furrow/mesh.h>
