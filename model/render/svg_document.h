// SvgDocument: a minimal writer of SVG 1.1 text shared by the renderers, so
// that escaping and number formatting live in one place.
//
// Plain value type; not synchronised (use one per thread). Coordinates are in
// pixels, y pointing down as in SVG.
#pragma once

#include <string>

namespace mm::render {

// `text` with &, <, >, " and ' replaced by XML entities, for text content and
// attribute values alike.
std::string xml_escape(const std::string& text);

// A pixel coordinate with one decimal ("12.5"; "-0" prints as "0"), enough for
// drawings and a fraction of the size of full precision.
std::string px(double value);

// 1, 2 or 5 times a power of ten, near `rough` (> 0): the step between an
// axis's ticks.
double nice_tick_step(double rough);

class SvgDocument {
 public:
  // Opens the document: an <svg> element of the given size (pixels) with a
  // white background.
  SvgDocument(double width, double height);

  // Straight line from (x1, y1) to (x2, y2). `extra` is appended inside the
  // element verbatim (e.g. "stroke-opacity=\"0.5\""); callers pass constant
  // text or escape what they put there.
  void line(double x1, double y1, double x2, double y2, const std::string& stroke, double width,
            const std::string& extra = "");
  void circle(double cx, double cy, double r, const std::string& fill);
  void rect(double x, double y, double w, double h, const std::string& fill, const std::string& stroke);
  // `points` is "x,y x,y ..." as built with px().
  void polyline(const std::string& points, const std::string& stroke, double width, const std::string& extra = "");
  // `anchor` is start, middle or end; `text` is escaped here.
  void text(double x, double y, const std::string& text, double size, const std::string& anchor = "start",
            const std::string& fill = "#222", const std::string& extra = "");

  // The complete document, closed with </svg> and a final newline.
  std::string finish() const;

 private:
  std::string body_;
};

}  // namespace mm::render
