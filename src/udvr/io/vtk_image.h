#pragma once
// VTK plumbing of the .vti and .pvti readers and writers (vti_io.cpp: fields, TF2s, array lists;
// vti_model_io.cpp: models; vti_model_stream.cpp: the out-of-core model writer): VTK's errors as
// one line, ImageData read whole (a .pvti's pieces assembled) or checked (vti_check.h), grids,
// arrays as float, atomic writes, field data. Private to io/; it includes VTK, which nothing
// outside io/ may.
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkDataCompressor.h>
#include <vtkDataObject.h>
#include <vtkDoubleArray.h>
#include <vtkErrorCode.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkLogger.h>
#include <vtkMatrix3x3.h>
#include <vtkNew.h>
#include <vtkOutputWindow.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkStringArray.h>
#include <vtkUnsignedCharArray.h>
#include <vtkXMLDataElement.h>
#include <vtkXMLDataParser.h>
#include <vtkXMLImageDataWriter.h>

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "udvr/io/vti_check.h"
#include "udvr/util/field.h"

namespace udvr {
struct ModelVolume;
}

namespace udvr::vtkio {
namespace fs = std::filesystem;

/// Collects the errors a VTK object reports, so they become one UdvrError line instead of text
/// on VTK's output window.
class ErrorCollector : public vtkCommand {
  public:
    static ErrorCollector* New() { return new ErrorCollector; }
    void Execute(vtkObject*, unsigned long, void* callData) override {
        ++count;
        if (!message.empty() || callData == nullptr) return;
        // VTK passes "ERROR: In file, line N\nClass (0x…): text\n\n"; keep the text.
        std::string text = static_cast<const char*>(callData);
        std::size_t nl = text.find('\n');
        if (nl != std::string::npos) text = text.substr(nl + 1);
        std::size_t cls = text.find("): ");
        if (cls != std::string::npos) text = text.substr(cls + 3);
        std::replace(text.begin(), text.end(), '\n', ' ');
        while (!text.empty() && text.back() == ' ') text.pop_back();
        message = text;
    }
    int count = 0;
    std::string message;
};

/// VTK's objects report errors on the output window besides the observers of the reader; the
/// reader's error, collected, is the one line to show. Called before any VTK use.
void silenceVtk();
/// A reader of `path` with its errors collected; fails unless VTK says it can read the file.
vtkSmartPointer<detail::CheckedVtiReader> newReader(const fs::path& path, ErrorCollector* errors);
/// Throws for a read that went wrong: what the checks found (vti_check.h), else VTK's first
/// error.
void throwIfFailed(const fs::path& path, detail::CheckedVtiReader* reader,
                   const ErrorCollector* errors, bool failed);
/// Read a VTK ImageData file (.vti, or a .pvti and its pieces as one image); with maxPoints > 0,
/// a whole extent of more points is refused from the header, before any data is allocated.
vtkSmartPointer<vtkImageData> readImageData(const fs::path& path, double maxPoints = 0);

// ---- partitioned images (.pvti, VTK's parallel ImageData) ------------------------------------

/// A .pvti's pieces as ParaView's writer names them: <dir>/<stem>/<stem>_<i>.vti, Source
/// relative to the .pvti's folder.
std::string pieceSource(const fs::path& pvti, int piece);
/// One piece of a .pvti: its file and its point extent within the whole extent.
struct PvtiPiece {
    fs::path file;
    std::array<long long, 6> extent{};
};

struct PvtiHeader {
    std::array<long long, 6> wholeExtent{};
    std::array<double, 3> origin{}, spacing{};
    std::vector<PvtiPiece> pieces;
};

/// Parses and checks a .pvti (VTKFile type="PImageData"): a whole extent, origin, spacing and
/// pieces whose extents lie inside it.
PvtiHeader readPvtiHeader(const fs::path& path);

// ---- grids and arrays ----------------------------------------------------------------------

/// The image's grid; a Direction other than the identity is ignored, which *note (when given)
/// says.
Grid3 gridOf(const fs::path& path, vtkImageData* image, std::string* note);
/// A VTK data type as uint8 … float64 (ArrayInfo::type, ScalarField::valueType).
std::string vtkTypeName(int type);
/// All tuples × components of a numeric array as float.
std::vector<float> toFloat(const fs::path& path, vtkDataArray* array);
/// The point arrays' names, for messages.
std::string arrayNames(vtkPointData* pd);
/// Let VTK see our floats without a copy; the writer only reads them.
vtkSmartPointer<vtkFloatArray> wrapFloats(const std::vector<float>& values, int components,
                                          const char* name);
/// An image of the grid's extent, origin and spacing, without arrays.
vtkSmartPointer<vtkImageData> makeImage(const Grid3& grid);

// ---- writing -------------------------------------------------------------------------------

/// Block compression of appended data. Both are read by VTK ≥ 8.1 and ParaView ≥ 5.5.
enum class Compression {
    Zlib,  // ParaView's default; best ratio on smooth fields
    Lz4,   // model files: on float statistics zlib (level 5) saves ~10 % of the size at ~20×
           // the time (64³ model, 26 MB: 0.62 s vs 0.03 s to write; 0.11 s vs 0.01 s to read)
    None,  // `build --no-compress`: raw appended data
};

/// Binary appended, block-compressed, 64-bit headers: ParaView's default kind of .vti.
void configureWriter(vtkXMLImageDataWriter* writer, Compression compression);
/// Write `image` as configureWriter says, atomically.
void writeImageData(const fs::path& path, vtkImageData* image,
                    Compression compression = Compression::Zlib);

// ---- field data ----------------------------------------------------------------------------

void addDouble(vtkFieldData* fd, const char* name, std::vector<double> values);
void addInt(vtkFieldData* fd, const char* name, int value);
void addString(vtkFieldData* fd, const char* name, const std::string& value);
std::vector<double> getDoubles(vtkFieldData* fd, const char* name);
double getDouble(vtkFieldData* fd, const char* name, double fallback);
int getInt(const fs::path& path, vtkFieldData* fd, const char* name, int fallback);
std::string getString(vtkFieldData* fd, const char* name, const std::string& fallback);
/// The model's field data (SPEC §7); hasQuantiles/hasGmm: whether the file holds those arrays.
void addModelFieldData(vtkFieldData* fd, const ModelVolume& model, bool hasQuantiles, bool hasGmm);

}  // namespace udvr::vtkio
