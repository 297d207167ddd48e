// The single translation unit that compiles tinygltf, stb_image and stb_image_write (Debian ships the
// headers; compiling them here keeps the loader callbacks under our control).
#define TINYGLTF_IMPLEMENTATION
// Only the two image formats glTF 2.0 allows, which is what decode_image documents: the other decoders of
// stb_image 2.27 (Debian 12), GIF, PSD, PIC, PNM, HDR, TGA and BMP, have memory-safety bugs fixed only in
// later releases, and a fuzzer reaches them through any texture or mask whose bytes are not PNG or JPEG.
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define TINYGLTF_NO_INCLUDE_STB_IMAGE
#define TINYGLTF_NO_INCLUDE_STB_IMAGE_WRITE
#include <stb_image.h>
#include <stb_image_write.h>
#include <tiny_gltf.h>
