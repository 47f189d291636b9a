#include "model/render/svg_document.h"

#include <cmath>
#include <cstdio>

namespace mm::render {

std::string xml_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

double nice_tick_step(double rough) {
  const double power = std::pow(10.0, std::floor(std::log10(rough)));
  const double fraction = rough / power;
  return (fraction < 1.5 ? 1 : fraction < 3.5 ? 2 : fraction < 7.5 ? 5 : 10) * power;
}

std::string px(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.1f", value);
  std::string s(buffer);
  if (s == "-0.0") return "0";
  if (s.size() > 2 && s.compare(s.size() - 2, 2, ".0") == 0) s.resize(s.size() - 2);
  return s;
}

SvgDocument::SvgDocument(double width, double height) {
  body_ = "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" + px(width) + "\" height=\"" +
          px(height) + "\" viewBox=\"0 0 " + px(width) + " " + px(height) +
          "\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\">\n";
  rect(0, 0, width, height, "white", "none");
}

void SvgDocument::line(double x1, double y1, double x2, double y2, const std::string& stroke, double width,
                       const std::string& extra) {
  body_ += "<line x1=\"" + px(x1) + "\" y1=\"" + px(y1) + "\" x2=\"" + px(x2) + "\" y2=\"" + px(y2) +
           "\" stroke=\"" + xml_escape(stroke) + "\" stroke-width=\"" + px(width) + "\" stroke-linecap=\"round\"" +
           (extra.empty() ? "" : " " + extra) + "/>\n";
}

void SvgDocument::circle(double cx, double cy, double r, const std::string& fill) {
  body_ += "<circle cx=\"" + px(cx) + "\" cy=\"" + px(cy) + "\" r=\"" + px(r) + "\" fill=\"" + xml_escape(fill) +
           "\"/>\n";
}

void SvgDocument::rect(double x, double y, double w, double h, const std::string& fill, const std::string& stroke) {
  body_ += "<rect x=\"" + px(x) + "\" y=\"" + px(y) + "\" width=\"" + px(w) + "\" height=\"" + px(h) +
           "\" fill=\"" + xml_escape(fill) + "\" stroke=\"" + xml_escape(stroke) + "\"/>\n";
}

void SvgDocument::polyline(const std::string& points, const std::string& stroke, double width,
                           const std::string& extra) {
  body_ += "<polyline points=\"" + points + "\" fill=\"none\" stroke=\"" + xml_escape(stroke) +
           "\" stroke-width=\"" + px(width) + "\" stroke-linejoin=\"round\"" + (extra.empty() ? "" : " " + extra) +
           "/>\n";
}

void SvgDocument::text(double x, double y, const std::string& text, double size, const std::string& anchor,
                       const std::string& fill, const std::string& extra) {
  body_ += "<text x=\"" + px(x) + "\" y=\"" + px(y) + "\" font-size=\"" + px(size) + "\" text-anchor=\"" + anchor +
           "\" fill=\"" + xml_escape(fill) + "\"" + (extra.empty() ? "" : " " + extra) + ">" + xml_escape(text) +
           "</text>\n";
}

std::string SvgDocument::finish() const { return body_ + "</svg>\n"; }

}  // namespace mm::render
