// Decodes every message of a log written by write_all_types with the project's types jar, the
// way lcm-spy does: the class is found by the message's fingerprint, not by its channel.
import java.io.ByteArrayInputStream;
import java.io.DataInputStream;
import java.io.IOException;
import java.util.HashMap;
import java.util.Map;

import lcm.logging.Log;
import lcm.spy.LCMTypeDatabase;

public class DecodeAll {
  public static void main(String[] args) throws Exception {
    LCMTypeDatabase db = new LCMTypeDatabase();
    Log log = new Log(args[0], "r");
    Map<String, Object> decoded = new HashMap<>();
    int passed = 0, failed = 0;
    while (true) {
      Log.Event ev;
      try {
        ev = log.readNext();
      } catch (IOException eof) {
        break;
      }
      DataInputStream in = new DataInputStream(new ByteArrayInputStream(ev.data));
      long fingerprint = in.readLong();
      Class<?> cls = db.getClassByFingerprint(fingerprint);
      String expected = "ptzstereo." + ev.channel;
      if (cls == null || !cls.getName().equals(expected)) {
        System.out.println("FAIL " + ev.channel + ": no class for its fingerprint in the jar");
        failed++;
        continue;
      }
      Object msg = cls.getConstructor(byte[].class).newInstance(ev.data);
      decoded.put(ev.channel, msg);
      System.out.println("ok   " + ev.channel + " -> " + cls.getName());
      passed++;
    }
    // A few known values, decoded in Java.
    failed += check(((ptzstereo.stereo_frame_t) decoded.get("stereo_frame_t")).seq == 42, "seq");
    failed += check(((ptzstereo.image_t) decoded.get("image_t")).data[5] == 6, "image data");
    failed += check(((ptzstereo.process_status_t) decoded.get("process_status_t")).counters[0].value
        == 300, "status counter");
    ptzstereo.object_3d_t pose_obj = ((ptzstereo.object_pose_t) decoded.get("object_pose_t")).objects[0];
    failed += check(pose_obj.position_m[2] == 3.0, "pose z");
    failed += check(pose_obj.has_orientation && pose_obj.orientation_wxyz[0] == 0.5
        && pose_obj.orientation_wxyz[2] == -0.5 && pose_obj.orientation_covariance_rad2[4] == 0.01,
        "pose orientation");
    ptzstereo.sim_object_truth_t truth_obj =
        ((ptzstereo.sim_truth_t) decoded.get("sim_truth_t")).objects[0];
    failed += check(truth_obj.shape.equals("box") && truth_obj.orientation_wxyz[0] == 0.25
        && truth_obj.orientation_wxyz[2] == 0.75 && truth_obj.visible_fraction[1] == 0.625,
        "truth orientation and visibility");
    ptzstereo.object_tracks_t tracks = (ptzstereo.object_tracks_t) decoded.get("object_tracks_t");
    failed += check(tracks.num_tracks == 2 && tracks.tracks[1].id == 8 && tracks.target_id == 7
        && tracks.tracks[0].state == ptzstereo.object_track_t.STATE_COASTING
        && tracks.tracks[0].has_orientation && tracks.tracks[0].velocity_m_s[0] == -0.25
        && tracks.target_reason.equals("locked on track 7 (green_box) by track id"), "tracks");
    ptzstereo.target_select_t select = (ptzstereo.target_select_t) decoded.get("target_select_t");
    failed += check(select.mode == ptzstereo.target_select_t.MODE_IMAGE_POINT
        && select.camera == ptzstereo.target_select_t.CAMERA_RIGHT && select.x_px == 412.5
        && select.frame_seq == -1, "target select");
    ptzstereo.control_state_t control =
        (ptzstereo.control_state_t) decoded.get("control_state_t");
    failed += check(control.state == ptzstereo.control_state_t.STATE_COASTING
        && control.target_id == 7 && control.since_target_s == 0.25 && control.search_waypoint == -1
        && control.reason.equals("target hidden: following its prediction"), "control state");
    if (decoded.size() != Integer.parseInt(args[1])) {
      System.out.println("FAIL expected " + args[1] + " types, decoded " + decoded.size());
      failed++;
    }
    System.out.println(passed + " passed, " + failed + " failed");
    System.exit(failed == 0 ? 0 : 1);
  }

  static int check(boolean ok, String what) {
    if (!ok) System.out.println("FAIL value check: " + what);
    return ok ? 0 : 1;
  }
}
