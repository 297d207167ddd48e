# All dependencies are Debian packages (see README); nothing is downloaded at build time.
find_package(Threads REQUIRED)
find_package(OpenMesh REQUIRED)          # OpenMeshCore: OBJ/PLY/OFF/STL readers, halfedge topology
find_package(CGAL REQUIRED)              # AABB trees, self-intersections (kept in few .cpp files)
find_package(TBB REQUIRED)               # deterministic parallel_for over fixed ranges
find_package(CLI11 REQUIRED)
find_package(nlohmann_json REQUIRED)
find_package(glm REQUIRED)
# meshoptimizer (Debian libmeshoptimizer-dev 0.18 ships a CMake config): vertex cache/fetch order, and the
# EXT_meshopt_compression codec. Private to furrow::mesh; no meshoptimizer type crosses a public header.
find_package(meshoptimizer CONFIG QUIET)
if(NOT TARGET meshoptimizer::meshoptimizer)
  find_path(MESHOPTIMIZER_INCLUDE_DIR meshoptimizer.h REQUIRED)
  find_library(MESHOPTIMIZER_LIBRARY NAMES meshoptimizer REQUIRED)
  add_library(meshoptimizer::meshoptimizer UNKNOWN IMPORTED)
  set_target_properties(meshoptimizer::meshoptimizer PROPERTIES IMPORTED_LOCATION ${MESHOPTIMIZER_LIBRARY}
    INTERFACE_INCLUDE_DIRECTORIES ${MESHOPTIMIZER_INCLUDE_DIR})
endif()

# tinygltf: Debian ships a shared libtinygltf built with stb + nlohmann; we compile the header ourselves
# (mesh/src/tinygltf_impl.cpp) so that the image loader can be replaced and no ABI surprise leaks.
find_path(TINYGLTF_INCLUDE_DIR tiny_gltf.h REQUIRED)
find_path(STB_INCLUDE_DIR stb_image.h PATH_SUFFIXES stb REQUIRED)

# OpenSubdiv: Debian's OpenSubdivConfig.cmake references libosdCPU.a, which the package does not ship,
# so find_package(OpenSubdiv CONFIG) fails. Locate the header and the shared osdCPU library directly.
find_path(OPENSUBDIV_INCLUDE_DIR opensubdiv/version.h REQUIRED)
find_library(OPENSUBDIV_CPU_LIBRARY NAMES osdCPU REQUIRED)
if(NOT TARGET furrow_opensubdiv)
  add_library(furrow_opensubdiv INTERFACE)
  target_include_directories(furrow_opensubdiv SYSTEM INTERFACE ${OPENSUBDIV_INCLUDE_DIR})
  target_link_libraries(furrow_opensubdiv INTERFACE ${OPENSUBDIV_CPU_LIBRARY})
endif()

# Warnings for our own code only.
set(FURROW_WARNINGS -Wall -Wextra -Wno-unused-parameter)

# Adds a furrow layer library: furrow_add_library(name SOURCES ... ) -> target furrow_<name>, alias furrow::<name>
function(furrow_add_library name)
  cmake_parse_arguments(A "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(furrow_${name} ${A_SOURCES})
  add_library(furrow::${name} ALIAS furrow_${name})
  set_target_properties(furrow_${name} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME furrow_${name})
  target_include_directories(furrow_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(furrow_${name} PUBLIC ${A_PUBLIC_DEPS} PRIVATE ${A_PRIVATE_DEPS})
  # The private geometry kernel (mesh/kernel/furrow_kernel): shared by every module, never installed.
  target_include_directories(furrow_${name} PRIVATE $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/mesh/kernel>)
  target_link_libraries(furrow_${name} PRIVATE glm::glm) # the kernel's vector type (furrow_kernel/vec3.h)
  target_compile_options(furrow_${name} PRIVATE ${FURROW_WARNINGS})
  install(TARGETS furrow_${name} EXPORT furrowTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endfunction()
