#pragma once
// Cairo helpers shared by the figure renderers of eval/ (not part of the public API): owned
// surfaces and contexts, pasting ImageRgba pixels in and out, and text. Pixels, top-left origin.
#include <cairo.h>

#include <functional>
#include <memory>
#include <string>

#include "udvr/classify/transfer_function.h"
#include "udvr/io/image.h"

namespace udvr::detail {

struct SurfaceDeleter {
    void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
struct ContextDeleter {
    void operator()(cairo_t* c) const { cairo_destroy(c); }
};
using SurfacePtr = std::unique_ptr<cairo_surface_t, SurfaceDeleter>;
using ContextPtr = std::unique_ptr<cairo_t, ContextDeleter>;

/// A new image surface; throws UdvrError when cairo cannot make one.
SurfacePtr makeSurface(cairo_format_t format, int width, int height);
/// Paste straight RGB (opaque) into an ARGB32/RGB24 surface at (x0, y0), clipped to it.
void pasteImage(cairo_surface_t* surface, const ImageRgba& image, int x0, int y0);
/// Read an opaque ARGB32 surface back into [0,1] floats (alpha 1).
ImageRgba surfaceToImage(cairo_surface_t* surface);
/// Select the figures' font (DejaVu Sans) at `size` pixels.
void setFont(cairo_t* cr, double size, bool bold);
/// Draw text with its horizontal centre at cx and baseline at y, shrunk to fit maxWidth.
void textCentred(cairo_t* cr, const std::string& text, double cx, double y, double maxWidth,
                 double size, bool bold);
/// Draw text with its baseline at y; alignX 0 puts its left end at x, 0.5 its centre, 1 its
/// right end.
void textAt(cairo_t* cr, const std::string& text, double x, double y, double size, bool bold,
            double alignX = 0.0);
/// A tick label for value v on an axis whose ticks are `step` apart (enough decimals for step).
std::string formatTick(double v, double step);

/// A plot frame: the rectangle [left, left + width] × [top, top + height] (pixels) outlined,
/// "nice" ticks with labels for x over [x0, x1] (below) and y over [y0, y1] (left, y up), and
/// the axis labels (y's rotated); `font` in pixels. Black, 1 px lines.
struct PlotAxes {
    double left = 0, top = 0, width = 0, height = 0;
    double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
    std::string xLabel, yLabel;
    double font = 12;
};
void drawAxes(cairo_t* cr, const PlotAxes& axes);

/// One pixel column per value over [x0, x1] from `left` (`columns` wide, `height` tall from
/// `top`), each filled with the TF's colour at the column's centre.
void fillTfColour(cairo_t* cr, const TransferFunction1D& tf, double x0, double x1, double left,
                  double top, int columns, double height);
/// A polyline through (left + c + 0.5, y(c)) for c = 0 … columns − 1, stroked in the current
/// source colour with `lineWidth`.
void strokeColumns(cairo_t* cr, double left, int columns, const std::function<double(int)>& y,
                   double lineWidth);

}  // namespace udvr::detail
