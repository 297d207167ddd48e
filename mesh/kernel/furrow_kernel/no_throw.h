// furrow's private geometry kernel: the public API's no-exception promise (mesh.h: "errors come back as a
// Status, never as an exception"), kept in one place. furrow's own code does not throw, but the standard
// library and TBB do: any std::vector, std::string or task can throw std::bad_alloc when memory runs out, and
// a container asked for more than max_size() throws std::length_error. The size guards refuse the requests
// furrow can foresee (a 1e12-byte buffer, a 20000² image); this catches the rest. Every public entry point
// that returns a Status runs its body through no_throw, so an engine that links furrow never sees an
// exception cross the API, only StatusCode::out_of_memory with what was being done.
#pragma once

#include <furrow/mesh.h>

#include <new>
#include <stdexcept>
#include <string>

namespace furrow::kernel {

// Runs body() (which returns a Status) and turns an allocation failure into out_of_memory "out of memory
// while <doing>".
template <class Body>
Status no_throw(const char* doing, Body&& body) noexcept {
    try {
        return body();
    } catch (const std::bad_alloc&) {
    } catch (const std::length_error&) {
    }
    return Status::error(StatusCode::out_of_memory, std::string("out of memory while ") + doing);
}

} // namespace furrow::kernel
