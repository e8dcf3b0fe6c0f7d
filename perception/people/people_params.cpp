#include "perception/people/people_params.hpp"

#include <opencv2/objdetect.hpp>

#include <fstream>
#include <set>

#include "common/config.hpp"

namespace ptz::perception {

PeopleClass defaultPeopleClass(const std::string& detector) {
  PeopleClass c;
  c.detector = detector;
  if (detector == "cascade") {
    // A frontal face cascade's box holds brow to chin and cheek to cheek: square, the face's size.
    c.cascade = "haarcascade_frontalface_default";
    c.height_m = 0.22;
    c.box_height_ratio = 0.8;
    c.box_aspect = 1.0;
    c.min_box_px = 24;
    c.centre_above_box_fraction = 0;
    c.patch_width_fraction = 0.7;
    c.patch_height_fraction = 0.8;
    c.scan_scale = 0.75;
    c.max_box_fraction = 0.3;
  }
  return c;
}

void loadCascade(const std::string& cascade, cv::CascadeClassifier* out) {
  const bool packaged = cascade.find('/') == std::string::npos && !cascade.empty() &&
                        cascade.find('.') == std::string::npos;
  if (packaged) {
    // Debian opencv-data's own XML, as the package manager installed it.
    for (const char* dir :
         {"/usr/share/opencv4/haarcascades/", "/usr/share/opencv4/lbpcascades/"}) {
      const std::string path = dir + cascade + ".xml";
      if (std::ifstream(path).good() && out->load(path) && !out->empty()) return;
    }
    throw ConfigError("cascade '" + cascade +
                      "': not one of /usr/share/opencv4/{haar,lbp}cascades/*.xml (Debian: "
                      "install opencv-data)");
  }
  // Anything else goes through the checked YAML reader (OpenCV's XML reader crashes on a few
  // bytes): a cascade of one's own, saved as YAML.
  const cv::FileStorage fs = openForRead(cascade, "cascade file");
  bool loaded = false;
  try {
    loaded = out->read(fs.getFirstTopLevelNode());
  } catch (const cv::Exception& e) {
    throw ConfigError("cascade file '" + cascade + "': " + e.what());
  }
  if (!loaded || out->empty()) {
    throw ConfigError("cascade file '" + cascade + "': not a cascade classifier");
  }
}

std::vector<PeopleClass> peopleClassesFromConfig(const cv::FileNode& people,
                                                 const std::string& where) {
  std::vector<PeopleClass> classes;
  if (people.empty() || people.isNone()) return classes;
  if (!people.isSeq()) throw ConfigError(where + ", people: must be a list");
  int i = 0;
  std::set<std::string> names;
  for (const auto& n : people) {
    const std::string w = where + ", people[" + std::to_string(i++) + "]";
    checkFields(n, {"name", "detector", "cascade", "height_m", "scan_scale", "min_neighbors"}, w);
    const std::string detector = n["detector"].empty() ? "hog" : readString(n, "detector", w);
    if (detector != "hog" && detector != "cascade") {
      throw ConfigError(fieldPath(w, "detector") + ": must be hog or cascade, got '" + detector +
                        "'");
    }
    PeopleClass c = defaultPeopleClass(detector);
    c.name = readString(n, "name", w);
    if (c.name.empty() || c.name.find('#') != std::string::npos) {
      throw ConfigError(fieldPath(w, "name") + ": must be non-empty and without '#', got '" +
                        c.name + "'");
    }
    if (!names.insert(c.name).second) {
      throw ConfigError(fieldPath(w, "name") + ": a second class named '" + c.name + "'");
    }
    if (!n["cascade"].empty()) {
      if (detector != "cascade")
        throw ConfigError(fieldPath(w, "cascade") + ": for detector cascade");
      c.cascade = readString(n, "cascade", w);
    }
    if (detector == "cascade") {
      cv::CascadeClassifier probe;
      loadCascade(c.cascade, &probe);  // throws naming the file
    }
    c.height_m = readDouble(n, "height_m", w, c.height_m, Range::between(0.02, 5));
    c.scan_scale = readDouble(n, "scan_scale", w, c.scan_scale, Range::between(0.1, 2));
    if (!n["min_neighbors"].empty()) {
      c.min_neighbors = readInt(n, "min_neighbors", w, Range::between(1, 20));
    }
    classes.push_back(c);
  }
  return classes;
}

}  // namespace ptz::perception
