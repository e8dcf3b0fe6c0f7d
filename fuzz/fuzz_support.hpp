// What the fuzz targets share: a property check that aborts (libFuzzer then keeps the input as a
// crash), the input as a file for the loaders that take a path, and a count of the bytes
// allocated while a call runs (through the sanitizer's malloc hooks).
#pragma once

#include <algorithm>

#include <sanitizer/allocator_interface.h>
#include <unistd.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

// Aborts with the property and `why` (a std::string expression, built only on failure).
#define FUZZ_CHECK(cond, why)                                                                     \
  do {                                                                                            \
    if (!(cond)) {                                                                                \
      std::fprintf(stderr, "\nproperty violated at %s:%d: %s\n  %s\n", __FILE__, __LINE__, #cond, \
                   std::string(why).c_str());                                                     \
      std::abort();                                                                               \
    }                                                                                             \
  } while (0)

namespace ptz::fuzz {

// The bytes malloc/new handed out between start() and bytes() (frees not subtracted: an upper
// bound of the peak). One thread only; the hooks are installed once per process.
class AllocationCount {
 public:
  AllocationCount() {
    static const bool installed = __sanitizer_install_malloc_and_free_hooks(onMalloc, onFree);
    (void)installed;
    start();
  }
  ~AllocationCount() { counting() = false; }
  void start() {
    allocated() = 0;
    counting() = true;
  }
  size_t bytes() const { return allocated(); }

 private:
  static std::atomic<bool>& counting() {
    static std::atomic<bool> on{false};
    return on;
  }
  static std::atomic<size_t>& allocated() {
    static std::atomic<size_t> n{0};
    return n;
  }
  static void onMalloc(const volatile void*, size_t size) {
    if (counting()) allocated() += size;
  }
  static void onFree(const volatile void*) {}
};

// A file holding the input, for the loaders that take a path; removed when this goes. Under
// /dev/shm when there is one (no disk writes per run). `name` ends the path (e.g. "rig.yaml":
// OpenCV picks the format from the extension).
class InputFile {
 public:
  InputFile(const uint8_t* data, size_t size, const std::string& name) {
    const char* dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : std::getenv("TMPDIR");
    path_ = std::string(dir ? dir : "/tmp") + "/ptz-fuzz-" + std::to_string(getpid()) + "-" + name;
    std::FILE* f = std::fopen(path_.c_str(), "wb");
    if (!f || (size > 0 && std::fwrite(data, 1, size, f) != size) || std::fclose(f) != 0) {
      std::fprintf(stderr, "cannot write %s\n", path_.c_str());
      std::abort();
    }
  }
  ~InputFile() { std::remove(path_.c_str()); }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// The input as a serial line delivers it: its first byte picks the size of the pieces (1..32),
// the rest is fed a piece at a time, as reads return them. Empty when the input is.
struct Pieces {
  const uint8_t* data = nullptr;
  size_t size = 0;
  size_t piece = 1;
  template <class Feed>
  void forEach(Feed feed) const {
    for (size_t at = 0; at < size; at += piece) feed(data + at, std::min(piece, size - at));
  }
};
inline Pieces piecesOf(const uint8_t* data, size_t size) {
  if (size < 1) return {};
  return {data + 1, size - 1, 1 + static_cast<size_t>(data[0] % 32)};
}

// Whether `text` names `path` (errors about a file must say which).
inline bool names(const std::string& text, const std::string& path) {
  return text.find(path) != std::string::npos;
}

}  // namespace ptz::fuzz
