// libjpeg's error handling for decoders that must not abort the process: its errors longjmp
// back to the caller's setjmp(err.jump) with the message in err.text; warnings are ignored.
// Include after <cstdio> and <jpeglib.h>.
#pragma once

#include <csetjmp>

namespace ptz {

struct JpegError {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
  char text[JMSG_LENGTH_MAX];
};

inline void onJpegError(j_common_ptr info) {
  auto* err = reinterpret_cast<JpegError*>(info->err);
  (*info->err->format_message)(info, err->text);
  std::longjmp(err->jump, 1);
}

inline void ignoreJpegMessage(j_common_ptr, int) {}

}  // namespace ptz
