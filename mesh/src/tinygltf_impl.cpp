// The single translation unit that compiles tinygltf, stb_image and stb_image_write (Debian ships the
// headers; compiling them here keeps the loader callbacks under our control).
#define TINYGLTF_IMPLEMENTATION
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define TINYGLTF_NO_INCLUDE_STB_IMAGE
#define TINYGLTF_NO_INCLUDE_STB_IMAGE_WRITE
#include <stb_image.h>
#include <stb_image_write.h>
#include <tiny_gltf.h>
