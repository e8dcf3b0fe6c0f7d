// A real RTSP server on loopback for tests, as an IP camera would be: serves one MJPEG AVI file
// (recorded from the simulator) at rtsp://127.0.0.1:PORT/MOUNT over RTP/JPEG, paced by the
// file's timestamps. The frames are encoded again as I420 JPEG: RTP/JPEG (RFC 2435) carries only
// baseline 4:2:0/4:2:2 JPEG, and OpenCV's MJPG writer's frames arrive garbled otherwise (seen).
// Prints "ready" once it listens; exits on SIGTERM/SIGINT.
#include <glib-unix.h>
#include <gst/gst.h>
#include <gst/rtsp-server/rtsp-server.h>

#include <csignal>
#include <cstdio>
#include <string>

namespace {
GMainLoop* g_loop = nullptr;

gboolean quit(gpointer) {
  g_main_loop_quit(g_loop);
  return G_SOURCE_REMOVE;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s PORT MOUNT FILE.avi (MJPEG)\n", argv[0]);
    return 2;
  }
  gst_init(nullptr, nullptr);
  g_loop = g_main_loop_new(nullptr, FALSE);
  GstRTSPServer* server = gst_rtsp_server_new();
  gst_rtsp_server_set_address(server, "127.0.0.1");
  gst_rtsp_server_set_service(server, argv[1]);
  GstRTSPMediaFactory* factory = gst_rtsp_media_factory_new();
  const std::string launch = std::string("( filesrc location=\"") + argv[3] +
                             "\" ! avidemux ! jpegdec ! videoconvert ! video/x-raw,format=I420 ! "
                             "jpegenc quality=90 ! rtpjpegpay name=pay0 pt=26 )";
  gst_rtsp_media_factory_set_launch(factory, launch.c_str());
  gst_rtsp_media_factory_set_shared(factory, TRUE);
  GstRTSPMountPoints* mounts = gst_rtsp_server_get_mount_points(server);
  gst_rtsp_mount_points_add_factory(mounts, (std::string("/") + argv[2]).c_str(), factory);
  g_object_unref(mounts);
  if (gst_rtsp_server_attach(server, nullptr) == 0) {
    std::fprintf(stderr, "cannot listen on 127.0.0.1:%s\n", argv[1]);
    return 1;
  }
  g_unix_signal_add(SIGTERM, quit, nullptr);
  g_unix_signal_add(SIGINT, quit, nullptr);
  std::printf("ready\n");
  std::fflush(stdout);
  g_main_loop_run(g_loop);
  g_object_unref(server);
  g_main_loop_unref(g_loop);
  return 0;
}
