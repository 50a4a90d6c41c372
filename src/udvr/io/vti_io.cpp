// VTK XML ImageData (.vti): scalar fields and model volumes (SPEC §7). The VTK includes of the io
// module stay in this file and vti_check.cpp (what VTK's reader trusts, checked); VTK headers
// are heavy to compile.
#include <fcntl.h>
#include <unistd.h>
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

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "udvr/io/field_io.h"
#include "udvr/io/io_detail.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_2d_io.h"
#include "udvr/io/vti_check.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr {
namespace fs = std::filesystem;

namespace {

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

/// VTK's objects report errors on the output window (the XML parser, the pipeline executive,
/// the compressors: a dozen log lines on stderr for one bad file) besides the observers of the
/// reader; the reader's error, collected, is the one line to show. Called before any VTK use.
void silenceVtk() {
    static const bool silenced = [] {
        vtkOutputWindow::GetInstance()->SetDisplayModeToNever();
        vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
        return true;
    }();
    (void)silenced;
}

/// Fails for XML nested deeper than VTK's parser survives (vti_check.h), before it parses.
void requireXmlNesting(const fs::path& path) {
    if (const std::string problem = detail::xmlNestingProblem(path); !problem.empty())
        UDVR_FAIL(path.string() << ": " << problem << "; not a VTK XML file udvr reads");
}

/// A reader of `path` with its errors collected; fails unless VTK says it can read the file.
vtkSmartPointer<detail::CheckedVtiReader> newReader(const fs::path& path, ErrorCollector* errors) {
    silenceVtk();
    detail::requireFile(path);
    requireXmlNesting(path);
    auto reader = vtkSmartPointer<detail::CheckedVtiReader>::New();
    reader->AddObserver(vtkCommand::ErrorEvent, errors);
    reader->AddObserver(vtkCommand::WarningEvent, errors);
    const std::string name = path.string();
    if (!reader->CanReadFile(name.c_str()))
        UDVR_FAIL(name << ": not a VTK XML ImageData file (expected <VTKFile type=\"ImageData\">)");
    reader->SetFileName(name.c_str());
    return reader;
}

/// Throws for a read that went wrong: what the checks found (vti_check.h), else VTK's first
/// error.
void throwIfFailed(const fs::path& path, detail::CheckedVtiReader* reader,
                   const ErrorCollector* errors, bool failed) {
    if (!reader->problem().empty()) UDVR_FAIL(path.string() << ": " << reader->problem());
    if (failed || errors->count > 0 || reader->GetErrorCode() != 0)
        UDVR_FAIL(path.string() << ": cannot read VTK ImageData"
                                << (errors->message.empty() ? "" : ": ") << errors->message
                                << " (truncated or corrupt file?)");
}

vtkSmartPointer<vtkImageData> readPvti(const fs::path& path, double maxPoints);

/// Read a VTK ImageData file (.vti, or a .pvti and its pieces as one image); with maxPoints > 0,
/// a whole extent of more points is refused from the header, before any data is allocated.
vtkSmartPointer<vtkImageData> readImageData(const fs::path& path, double maxPoints = 0) {
    if (detail::lowerExtension(path) == ".pvti") return readPvti(path, maxPoints);
    vtkNew<ErrorCollector> errors;
    auto reader = newReader(path, errors);
    const std::string name = path.string();
    if (maxPoints > 0) {
        reader->UpdateInformation();
        throwIfFailed(path, reader, errors, false);
        const int* e =
            reader->GetOutputInformation(0)->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
        double points = 1;
        for (int a = 0; a < 3 && e; ++a) points *= static_cast<double>(e[2 * a + 1]) - e[2 * a] + 1;
        if (e && points > maxPoints)
            UDVR_FAIL(name << ": extent " << e[0] << " " << e[1] << " " << e[2] << " " << e[3]
                           << " " << e[4] << " " << e[5] << " has more than " << maxPoints
                           << " points");
    }
    reader->Update();
    vtkImageData* image = reader->GetOutput();
    throwIfFailed(path, reader, errors, image == nullptr);
    vtkSmartPointer<vtkImageData> out = image;
    return out;
}

// ---- partitioned images (.pvti, VTK's parallel ImageData) ------------------------------------

/// A .pvti's pieces as ParaView's writer names them: <dir>/<stem>/<stem>_<i>.vti, Source
/// relative to the .pvti's folder.
std::string pieceSource(const fs::path& pvti, int piece) {
    const std::string stem = pvti.stem().string();
    return stem + "/" + stem + "_" + std::to_string(piece) + ".vti";
}

/// `count` integers of an attribute of `e`, or an error naming the .pvti.
std::vector<long long> intsOf(const fs::path& path, vtkXMLDataElement* e, const char* name,
                              std::size_t count) {
    const char* text = e->GetAttribute(name);
    if (text == nullptr)
        UDVR_FAIL(path.string() << ": <" << e->GetName() << "> has no " << name << " attribute");
    std::istringstream in(text);
    std::vector<long long> v(count);
    for (long long& x : v) {
        if (!(in >> x) || std::llabs(x) > (1LL << 30))
            UDVR_FAIL(path.string() << ": <" << e->GetName() << "> " << name << "=\"" << text
                                    << "\" is not " << count << " integers");
    }
    std::string rest;
    if (in >> rest)
        UDVR_FAIL(path.string() << ": <" << e->GetName() << "> " << name << "=\"" << text
                                << "\" has more than " << count << " values");
    return v;
}

std::array<double, 3> doublesOf(const fs::path& path, vtkXMLDataElement* e, const char* name) {
    const char* text = e->GetAttribute(name);
    if (text == nullptr)
        UDVR_FAIL(path.string() << ": <" << e->GetName() << "> has no " << name << " attribute");
    std::istringstream in(text);
    std::array<double, 3> v{};
    for (double& x : v) {
        if (!(in >> x) || !std::isfinite(x))
            UDVR_FAIL(path.string() << ": <" << e->GetName() << "> " << name << "=\"" << text
                                    << "\" is not 3 finite numbers");
    }
    return v;
}

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
/// pieces whose extents lie inside it. The pieces are read by readImageData (checked as any
/// .vti); whether they cover the extent is checked when they are assembled.
PvtiHeader readPvtiHeader(const fs::path& path) {
    detail::requireFile(path);
    std::error_code ec;
    const auto bytes = fs::file_size(path, ec);
    if (!ec && bytes > (16u << 20))
        UDVR_FAIL(path.string() << ": " << bytes << " bytes is not a .pvti header (at most 16 MB)");
    requireXmlNesting(path);
    vtkNew<vtkXMLDataParser> parser;
    const std::string name = path.string();
    parser->SetFileName(name.c_str());
    if (parser->Parse() == 0 || parser->GetRootElement() == nullptr)
        UDVR_FAIL(name << ": not a VTK XML file (cannot parse it as XML)");
    vtkXMLDataElement* root = parser->GetRootElement();
    const char* type = root->GetAttribute("type");
    if (std::string(root->GetName()) != "VTKFile" || type == nullptr ||
        std::string(type) != "PImageData")
        UDVR_FAIL(name << ": not a parallel VTK ImageData file (expected <VTKFile "
                          "type=\"PImageData\">)");
    vtkXMLDataElement* image = root->FindNestedElementWithName("PImageData");
    if (image == nullptr) UDVR_FAIL(name << ": no <PImageData> element");
    PvtiHeader h;
    const auto whole = intsOf(path, image, "WholeExtent", 6);
    std::copy(whole.begin(), whole.end(), h.wholeExtent.begin());
    h.origin = doublesOf(path, image, "Origin");
    h.spacing = doublesOf(path, image, "Spacing");
    for (int a = 0; a < 3; ++a) {
        if (h.wholeExtent[2 * a] > h.wholeExtent[2 * a + 1])
            UDVR_FAIL(name << ": empty WholeExtent along axis " << a);
        if (!(h.spacing[a] > 0.0))
            UDVR_FAIL(name << ": Spacing along axis " << a << " is " << h.spacing[a]
                           << ", expected a positive number");
    }
    const fs::path folder = path.parent_path();
    for (int i = 0; i < image->GetNumberOfNestedElements(); ++i) {
        vtkXMLDataElement* e = image->GetNestedElement(i);
        if (std::string(e->GetName()) != "Piece") continue;
        if (h.pieces.size() >= 65536) UDVR_FAIL(name << ": more than 65536 pieces");
        PvtiPiece piece;
        const auto extent = intsOf(path, e, "Extent", 6);
        std::copy(extent.begin(), extent.end(), piece.extent.begin());
        for (int a = 0; a < 3; ++a) {
            if (piece.extent[2 * a] > piece.extent[2 * a + 1] ||
                piece.extent[2 * a] < h.wholeExtent[2 * a] ||
                piece.extent[2 * a + 1] > h.wholeExtent[2 * a + 1])
                UDVR_FAIL(name << ": piece " << h.pieces.size()
                               << " has an Extent outside the WholeExtent");
        }
        const char* source = e->GetAttribute("Source");
        if (source == nullptr || *source == '\0')
            UDVR_FAIL(name << ": piece " << h.pieces.size() << " has no Source file");
        piece.file = fs::path(source).is_absolute() ? fs::path(source) : folder / source;
        if (detail::lowerExtension(piece.file) != ".vti")
            UDVR_FAIL(name << ": piece " << h.pieces.size() << " is '" << source
                           << "', expected a .vti file");
        h.pieces.push_back(piece);
    }
    if (h.pieces.empty()) UDVR_FAIL(name << ": no <Piece> elements");
    return h;
}

/// The whole image of a .pvti: every piece read and checked as a .vti (its extent, origin and
/// spacing those the .pvti says), its point arrays copied into arrays of the whole extent (the
/// pieces share boundary planes; every point must be covered), the field data of piece 0.
vtkSmartPointer<vtkImageData> readPvti(const fs::path& path, double maxPoints) {
    const PvtiHeader h = readPvtiHeader(path);
    const std::string name = path.string();
    std::array<long long, 3> dims{};
    double points = 1;
    for (int a = 0; a < 3; ++a) {
        dims[a] = h.wholeExtent[2 * a + 1] - h.wholeExtent[2 * a] + 1;
        points *= static_cast<double>(dims[a]);
    }
    if (maxPoints > 0 && points > maxPoints)
        UDVR_FAIL(name << ": a whole extent of " << points << " points, more than " << maxPoints);
    if (points > 1e11) UDVR_FAIL(name << ": a whole extent of " << points << " points");
    auto whole = vtkSmartPointer<vtkImageData>::New();
    whole->SetExtent(static_cast<int>(h.wholeExtent[0]), static_cast<int>(h.wholeExtent[1]),
                     static_cast<int>(h.wholeExtent[2]), static_cast<int>(h.wholeExtent[3]),
                     static_cast<int>(h.wholeExtent[4]), static_cast<int>(h.wholeExtent[5]));
    whole->SetOrigin(h.origin.data());
    whole->SetSpacing(h.spacing.data());
    const auto n = static_cast<vtkIdType>(points);
    std::vector<bool> covered(static_cast<std::size_t>(n), false);
    vtkPointData* out = whole->GetPointData();
    for (std::size_t p = 0; p < h.pieces.size(); ++p) {
        const PvtiPiece& piece = h.pieces[p];
        double piecePoints = 1;
        for (int a = 0; a < 3; ++a)
            piecePoints *= static_cast<double>(piece.extent[2 * a + 1] - piece.extent[2 * a] + 1);
        const std::string what =
            name + ": piece " + std::to_string(p) + " (" + piece.file.string() + ")";
        vtkSmartPointer<vtkImageData> image;
        try {
            // At most as many points as its Extent in the .pvti (checked before VTK reads).
            image = readImageData(piece.file, piecePoints);
        } catch (const FileError& e) {
            UDVR_FILE_FAIL(name << ": piece " << p << ": " << e.what());
        } catch (const UdvrError& e) {
            UDVR_FAIL(name << ": piece " << p << ": " << e.what());
        }
        int e[6];
        double origin[3], spacing[3];
        image->GetExtent(e);
        image->GetOrigin(origin);
        image->GetSpacing(spacing);
        for (int a = 0; a < 6; ++a) {
            if (e[a] != piece.extent[a])
                UDVR_FAIL(what << " has extent " << e[0] << " " << e[1] << " " << e[2] << " "
                               << e[3] << " " << e[4] << " " << e[5]
                               << ", not the Extent the .pvti gives it");
        }
        for (int a = 0; a < 3; ++a) {
            const double tol =
                1e-9 * std::max(1.0, std::abs(h.spacing[a]) * static_cast<double>(dims[a]));
            if (std::abs(origin[a] - h.origin[a]) > tol ||
                std::abs(spacing[a] - h.spacing[a]) > 1e-9 * h.spacing[a])
                UDVR_FAIL(what << " has another origin or spacing than the .pvti");
        }
        vtkPointData* in = image->GetPointData();
        if (p == 0) {
            for (int i = 0; i < in->GetNumberOfArrays(); ++i) {
                vtkAbstractArray* a = in->GetAbstractArray(i);
                auto* numeric = vtkDataArray::SafeDownCast(a);
                if (numeric == nullptr || a->GetName() == nullptr) continue;
                vtkSmartPointer<vtkDataArray> copy;
                copy.TakeReference(numeric->NewInstance());
                copy->SetName(a->GetName());
                copy->SetNumberOfComponents(a->GetNumberOfComponents());
                copy->SetNumberOfTuples(n);
                out->AddArray(copy);
            }
            if (const char* active = in->GetScalars() ? in->GetScalars()->GetName() : nullptr)
                out->SetActiveScalars(active);
            whole->GetFieldData()->ShallowCopy(image->GetFieldData());
        }
        for (int i = 0; i < out->GetNumberOfArrays(); ++i) {
            vtkDataArray* dst = out->GetArray(i);
            vtkDataArray* src = in->GetArray(dst->GetName());
            if (src == nullptr || src->GetNumberOfComponents() != dst->GetNumberOfComponents())
                UDVR_FAIL(what << " has no point array '" << dst->GetName() << "' with "
                               << dst->GetNumberOfComponents() << " components, as piece 0 has");
            if (src->GetNumberOfTuples() != static_cast<vtkIdType>(piecePoints))
                UDVR_FAIL(what << ": array '" << dst->GetName() << "' holds "
                               << src->GetNumberOfTuples() << " tuples, its extent " << piecePoints
                               << " points");
        }
        // Row by row (x contiguous in both): a copy of the bytes where the types match.
        std::vector<std::pair<vtkDataArray*, vtkDataArray*>> pairs;  // (whole, piece)
        for (int a = 0; a < out->GetNumberOfArrays(); ++a)
            pairs.emplace_back(out->GetArray(a), in->GetArray(out->GetArray(a)->GetName()));
        const auto row = static_cast<vtkIdType>(piece.extent[1] - piece.extent[0] + 1);
        vtkIdType t = 0;
        for (long long k = piece.extent[4]; k <= piece.extent[5]; ++k)
            for (long long j = piece.extent[2]; j <= piece.extent[3]; ++j, t += row) {
                const auto at = static_cast<vtkIdType>(
                    ((k - h.wholeExtent[4]) * dims[1] + (j - h.wholeExtent[2])) * dims[0] +
                    (piece.extent[0] - h.wholeExtent[0]));
                std::fill_n(covered.begin() + at, row, true);
                for (const auto& [dst, src] : pairs) {
                    if (dst->GetDataType() == src->GetDataType()) {
                        const int c = dst->GetNumberOfComponents();
                        std::memcpy(dst->GetVoidPointer(at * c), src->GetVoidPointer(t * c),
                                    static_cast<std::size_t>(row * c) *
                                        static_cast<std::size_t>(dst->GetDataTypeSize()));
                    } else {
                        for (vtkIdType i = 0; i < row; ++i) dst->SetTuple(at + i, t + i, src);
                    }
                }
            }
    }
    const auto gap = std::find(covered.begin(), covered.end(), false);
    if (gap != covered.end()) {
        const auto at = static_cast<long long>(gap - covered.begin());
        UDVR_FAIL(name << ": the pieces do not cover point (" << at % dims[0] + h.wholeExtent[0]
                       << ", " << at / dims[0] % dims[1] + h.wholeExtent[2] << ", "
                       << at / dims[0] / dims[1] + h.wholeExtent[4] << ") of the WholeExtent");
    }
    return whole;
}

/// The image's grid; a Direction other than the identity is ignored, which *note (when given)
/// says, for the caller to print once the whole read succeeded.
Grid3 gridOf(const fs::path& path, vtkImageData* image, std::string* note) {
    Grid3 g;
    int extent[6];
    double origin[3], spacing[3];
    image->GetExtent(extent);
    image->GetOrigin(origin);
    image->GetSpacing(spacing);
    for (int a = 0; a < 3; ++a) {
        g.dims[a] = extent[2 * a + 1] - extent[2 * a] + 1;
        if (g.dims[a] < 1) UDVR_FAIL(path.string() << ": empty ImageData extent");
        if (!(spacing[a] > 0.0) || !std::isfinite(spacing[a])) {
            UDVR_FAIL(path.string() << ": spacing along axis " << a << " is " << spacing[a]
                                    << ", expected a positive number");
        }
        g.spacing[a] = spacing[a];
        // The point at index 0 of our grid is the extent's first point.
        g.origin[a] = origin[a] + extent[2 * a] * spacing[a];
    }
    if (vtkMatrix3x3* dir = image->GetDirectionMatrix();
        dir != nullptr && !dir->IsIdentity() && note != nullptr) {
        *note = "udvr: note: " + path.string() +
                ": the ImageData Direction is not the identity; ignoring the orientation";
    }
    return g;
}

/// A VTK data type as uint8 … float64 (ArrayInfo::type, ScalarField::valueType).
std::string vtkTypeName(int type) {
    switch (type) {
        case VTK_UNSIGNED_CHAR:
            return "uint8";
        case VTK_SIGNED_CHAR:
        case VTK_CHAR:
            return "int8";
        case VTK_UNSIGNED_SHORT:
            return "uint16";
        case VTK_SHORT:
            return "int16";
        case VTK_UNSIGNED_INT:
            return "uint32";
        case VTK_INT:
            return "int32";
        case VTK_FLOAT:
            return "float32";
        case VTK_DOUBLE:
            return "float64";
        default:
            return "VTK type " + std::to_string(type);
    }
}

template <class T>
void convertValues(const T* src, std::size_t n, float* dst) {
    for (std::size_t i = 0; i < n; ++i) dst[i] = static_cast<float>(src[i]);
}

/// All tuples × components of a numeric array as float.
std::vector<float> toFloat(const fs::path& path, vtkDataArray* array) {
    std::size_t n = static_cast<std::size_t>(array->GetNumberOfValues());
    std::vector<float> out(n);
    if (n == 0) return out;
    void* raw = array->GetVoidPointer(0);
    switch (array->GetDataType()) {
        vtkTemplateMacro(convertValues(static_cast<const VTK_TT*>(raw), n, out.data()));
        default:
            UDVR_FAIL(path.string() << ": array '" << (array->GetName() ? array->GetName() : "")
                                    << "' has unsupported type " << array->GetDataTypeAsString());
    }
    return out;
}

std::string arrayNames(vtkPointData* pd) {
    std::string names;
    for (int i = 0; i < pd->GetNumberOfArrays(); ++i) {
        const char* n = pd->GetArrayName(i);
        names += (i ? ", " : "");
        names += n ? n : "(unnamed)";
    }
    return names.empty() ? "none" : names;
}

/// Let VTK see our floats without a copy; the writer only reads them.
vtkSmartPointer<vtkFloatArray> wrapFloats(const std::vector<float>& values, int components,
                                          const char* name) {
    auto array = vtkSmartPointer<vtkFloatArray>::New();
    array->SetName(name);
    array->SetNumberOfComponents(components);
    array->SetArray(const_cast<float*>(values.data()), static_cast<vtkIdType>(values.size()),
                    /*save=*/1);
    return array;
}

vtkSmartPointer<vtkImageData> makeImage(const Grid3& grid) {
    auto image = vtkSmartPointer<vtkImageData>::New();
    image->SetDimensions(grid.dims[0], grid.dims[1], grid.dims[2]);
    image->SetOrigin(grid.origin[0], grid.origin[1], grid.origin[2]);
    image->SetSpacing(grid.spacing[0], grid.spacing[1], grid.spacing[2]);
    return image;
}

/// Block compression of appended data. Both are read by VTK ≥ 8.1 and ParaView ≥ 5.5.
enum class Compression {
    Zlib,  // ParaView's default; best ratio on smooth fields
    Lz4,   // model files: on float statistics zlib (level 5) saves ~10 % of the size at ~20×
           // the time (64³ model, 26 MB: 0.62 s vs 0.03 s to write; 0.11 s vs 0.01 s to read)
};

/// Binary appended, block-compressed, 64-bit headers: ParaView's default kind of .vti.
void configureWriter(vtkXMLImageDataWriter* writer, Compression compression) {
    writer->SetDataModeToAppended();
    writer->EncodeAppendedDataOff();
    if (compression == Compression::Lz4)
        writer->SetCompressorTypeToLZ4();
    else
        writer->SetCompressorTypeToZLib();
    writer->SetHeaderTypeToUInt64();
}

/// Write `image` as configureWriter says, atomically.
void writeImageData(const fs::path& path, vtkImageData* image,
                    Compression compression = Compression::Zlib) {
    silenceVtk();
    writeAtomically(path, [&](const fs::path& tmp) {
        vtkNew<vtkXMLImageDataWriter> writer;
        vtkNew<ErrorCollector> errors;
        writer->AddObserver(vtkCommand::ErrorEvent, errors);
        std::string name = tmp.string();
        writer->SetFileName(name.c_str());
        writer->SetInputData(image);
        configureWriter(writer, compression);
        errno = 0;
        const int ok = writer->Write();
        const int err = errno;  // the failed open or write (VTK's message names the temporary)
        if (ok != 1 || errors->count > 0 || writer->GetErrorCode() != 0) {
            std::string why = writeErrorText(err);
            if (why.empty()) why = errors->message;
            if (why.empty())
                why = writer->GetErrorCode() == vtkErrorCode::OutOfDiskSpaceError
                          ? std::string("out of disk space")
                          : "VTK error code " + std::to_string(writer->GetErrorCode());
            UDVR_FILE_FAIL("cannot write " << path.string() << ": " << why);
        }
    });
}

// ---- model field data ----------------------------------------------------------------------

void addDouble(vtkFieldData* fd, const char* name, std::vector<double> values) {
    vtkNew<vtkDoubleArray> a;
    a->SetName(name);
    for (double v : values) a->InsertNextValue(v);
    fd->AddArray(a);
}

void addInt(vtkFieldData* fd, const char* name, int value) {
    vtkNew<vtkIntArray> a;
    a->SetName(name);
    a->InsertNextValue(value);
    fd->AddArray(a);
}

void addString(vtkFieldData* fd, const char* name, const std::string& value) {
    vtkNew<vtkStringArray> a;
    a->SetName(name);
    a->InsertNextValue(value);
    fd->AddArray(a);
}

std::vector<double> getDoubles(vtkFieldData* fd, const char* name) {
    std::vector<double> out;
    auto* a = vtkDataArray::SafeDownCast(fd ? fd->GetAbstractArray(name) : nullptr);
    if (a == nullptr) return out;
    for (vtkIdType i = 0; i < a->GetNumberOfValues(); ++i) {
        out.push_back(a->GetComponent(i / a->GetNumberOfComponents(),
                                      static_cast<int>(i % a->GetNumberOfComponents())));
    }
    return out;
}

double getDouble(vtkFieldData* fd, const char* name, double fallback) {
    auto v = getDoubles(fd, name);
    return v.empty() ? fallback : v[0];
}

int getInt(const fs::path& path, vtkFieldData* fd, const char* name, int fallback) {
    double v = getDouble(fd, name, fallback);
    if (!std::isfinite(v) || v != std::floor(v) || std::abs(v) > 1e9) {
        UDVR_FAIL(path.string() << ": field data '" << name << "' is " << v
                                << ", expected an integer");
    }
    return static_cast<int>(v);
}

std::string getString(vtkFieldData* fd, const char* name, const std::string& fallback) {
    auto* a = vtkStringArray::SafeDownCast(fd ? fd->GetAbstractArray(name) : nullptr);
    if (a == nullptr || a->GetNumberOfValues() == 0) return fallback;
    return a->GetValue(0);
}

}  // namespace

// ---- fields ------------------------------------------------------------------------------------

ScalarField detail::readFieldVti(const fs::path& path, const std::string& var,
                                 std::string* geometryNote) {
    vtkSmartPointer<vtkImageData> image = readImageData(path);
    ScalarField f;
    f.grid = gridOf(path, image, geometryNote);
    vtkPointData* pd = image->GetPointData();
    vtkDataArray* array = nullptr;
    if (!var.empty()) {
        array = pd->GetArray(var.c_str());
        if (array == nullptr) {
            UDVR_FAIL(path.string()
                      << ": no point array '" << var << "' (arrays: " << arrayNames(pd) << ")");
        }
    } else {
        array = pd->GetScalars();
        if (array == nullptr && pd->GetNumberOfArrays() > 0) array = pd->GetArray(0);
        if (array == nullptr) UDVR_FAIL(path.string() << ": no numeric point data array");
    }
    std::string name = array->GetName() ? array->GetName() : "";
    if (array->GetNumberOfComponents() != 1) {
        UDVR_FAIL(path.string() << ": point array '" << name << "' has "
                                << array->GetNumberOfComponents()
                                << " components, expected a scalar (1 component)");
    }
    if (static_cast<std::size_t>(array->GetNumberOfTuples()) != f.grid.pointCount()) {
        UDVR_FAIL(path.string() << ": dims do not match the data: array '" << name << "' holds "
                                << array->GetNumberOfTuples() << " values, the grid "
                                << f.grid.pointCount());
    }
    f.values = toFloat(path, array);
    f.name = name;
    f.valueType = vtkTypeName(array->GetDataType());
    // Every numeric VTK type but these two holds integers.
    const bool floating = array->GetDataType() == VTK_FLOAT || array->GetDataType() == VTK_DOUBLE;
    f.valueStep = floating ? 0.0 : 1.0;
    return f;
}

void writeFieldVti(const fs::path& path, const ScalarField& field) {
    UDVR_CHECK_MSG(field.values.size() == field.grid.pointCount(), "field size vs grid");
    auto image = makeImage(field.grid);
    auto array = wrapFloats(field.values, 1, field.name.empty() ? "scalars" : field.name.c_str());
    image->GetPointData()->SetScalars(array);
    writeImageData(path, image);
}

// ---- models ------------------------------------------------------------------------------------

/// The model's field data (SPEC §7).
/// hasQuantiles/hasGmm: whether the file holds those arrays.
void addModelFieldData(vtkFieldData* fd, const ModelVolume& model, bool hasQuantiles, bool hasGmm) {
    addInt(fd, "quantile_count", hasQuantiles ? model.quantileCount : 0);
    if (hasQuantiles) {
        std::vector<double> levels(static_cast<std::size_t>(model.quantileCount) + 1);
        for (int j = 0; j <= model.quantileCount; ++j)
            levels[static_cast<std::size_t>(j)] = model.quantileLevel(j);
        addDouble(fd, "quantile_levels", levels);
    }
    addString(fd, "density", model.density);
    addDouble(fd, "bandwidth", {model.bandwidth});
    addString(fd, "bandwidth_rule", model.bandwidthRule);
    addDouble(fd, "tail_eps", {model.tailEps});
    addInt(fd, "samples_per_voxel", model.samplesPerVoxel);
    addInt(fd, "downsample", model.downsample);
    addDouble(fd, "bounds", std::vector<double>(model.bounds.begin(), model.bounds.end()));
    addDouble(fd, "full_res_min_spacing", {model.fullResMinSpacing});
    addInt(fd, "gmm_components", hasGmm ? model.gmmComponents : 0);
    addString(fd, "source", model.source);
}

namespace {

/// f(values, components, name) for each point array of a model file, in file order (SPEC §7);
/// an absent array has empty values.
template <typename F>
void forEachModelArray(const ModelVolume& model, F&& f) {
    for (const ModelFileArray& a : kModelFileArrays)
        f(model.*a.values, a.floatsPerVoxel(model), a.name);
}

/// The model's planes k0 … k1 (z) as an image whose extent is those planes of the whole grid
/// (the origin stays the grid's), with the model's field data.
vtkSmartPointer<vtkImageData> modelImage(const ModelVolume& model, int k0, int k1) {
    const std::size_t n = model.voxelCount();
    const std::size_t plane = static_cast<std::size_t>(model.grid.dims[0]) * model.grid.dims[1];
    UDVR_CHECK(0 <= k0 && k0 <= k1 && k1 < model.grid.dims[2]);
    auto image = makeImage(model.grid);
    image->SetExtent(0, model.grid.dims[0] - 1, 0, model.grid.dims[1] - 1, k0, k1);
    vtkPointData* pd = image->GetPointData();
    auto add = [&](const std::vector<float>& values, int components, const char* name) {
        if (values.empty()) return;
        UDVR_CHECK_MSG(values.size() == n * static_cast<std::size_t>(components),
                       std::string("model array size: ") + name);
        if (k0 == 0 && k1 == model.grid.dims[2] - 1) {
            pd->AddArray(wrapFloats(values, components, name));
            return;
        }
        // A copy of the planes (wrapFloats does not copy).
        const std::size_t c = static_cast<std::size_t>(components);
        const std::size_t begin = plane * c * static_cast<std::size_t>(k0);
        const std::size_t count = plane * c * static_cast<std::size_t>(k1 - k0 + 1);
        auto array = vtkSmartPointer<vtkFloatArray>::New();
        array->SetName(name);
        array->SetNumberOfComponents(components);
        array->SetNumberOfValues(static_cast<vtkIdType>(count));
        std::copy_n(values.begin() + static_cast<std::ptrdiff_t>(begin), count,
                    array->GetPointer(0));
        pd->AddArray(array);
    };
    forEachModelArray(model, add);
    if (!model.mean.empty()) pd->SetActiveScalars("mean");

    addModelFieldData(image->GetFieldData(), model, model.hasQuantiles(), model.hasGmm());
    return image;
}

}  // namespace

void writeModelVti(const fs::path& path, const ModelVolume& model) {
    writeImageData(path, modelImage(model, 0, model.grid.dims[2] - 1), Compression::Lz4);
}

std::vector<int> pvtiPieceBoundaries(int planes, int pieces) {
    UDVR_CHECK(planes >= 1 && pieces >= 1);
    const int cells = std::max(planes - 1, 1);
    pieces = std::min(pieces, cells);
    std::vector<int> b(static_cast<std::size_t>(pieces) + 1);
    for (int i = 0; i <= pieces; ++i)
        b[static_cast<std::size_t>(i)] =
            static_cast<int>(static_cast<long long>(i) * (planes - 1) / pieces);
    return b;
}

void writeModelPvtiPiece(const fs::path& path, const ModelVolume& model, int piece, int k0, int k1,
                         int modelFirstPlane) {
    const fs::path file = path.parent_path() / pieceSource(path, piece);
    std::error_code ec;
    fs::create_directories(file.parent_path(), ec);
    if (ec)
        UDVR_FILE_FAIL("cannot write " << path.string() << ": cannot create the folder "
                                       << file.parent_path().string() << ": " << ec.message());
    auto image = modelImage(model, k0 - modelFirstPlane, k1 - modelFirstPlane);
    if (modelFirstPlane != 0) {
        // `model` holds planes from modelFirstPlane on: the extent and origin of the whole grid.
        image->SetExtent(0, model.grid.dims[0] - 1, 0, model.grid.dims[1] - 1, k0, k1);
        image->SetOrigin(model.grid.origin[0], model.grid.origin[1],
                         model.grid.origin[2] - modelFirstPlane * model.grid.spacing[2]);
    }
    writeImageData(file, image, Compression::Lz4);
}

void writeModelPvtiHeader(const fs::path& path, const ModelVolume& model,
                          const std::vector<int>& boundaries) {
    const Grid3& g = model.grid;
    std::ostringstream x;
    x.precision(17);
    x << "<?xml version=\"1.0\"?>\n"
      << "<VTKFile type=\"PImageData\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\" compressor=\"vtkLZ4DataCompressor\">\n"
      << "  <PImageData WholeExtent=\"0 " << g.dims[0] - 1 << " 0 " << g.dims[1] - 1 << " 0 "
      << g.dims[2] - 1 << "\" GhostLevel=\"0\" Origin=\"" << g.origin[0] << " " << g.origin[1]
      << " " << g.origin[2] << "\" Spacing=\"" << g.spacing[0] << " " << g.spacing[1] << " "
      << g.spacing[2] << "\" Direction=\"1 0 0 0 1 0 0 0 1\">\n"
      << "    <PPointData" << (model.mean.empty() ? "" : " Scalars=\"mean\"") << ">\n";
    auto array = [&](const std::vector<float>& values, int components, const char* name) {
        if (values.empty()) return;
        x << "      <PDataArray type=\"Float32\" Name=\"" << name << "\"";
        if (components > 1) x << " NumberOfComponents=\"" << components << "\"";
        x << "/>\n";
    };
    forEachModelArray(model, array);
    x << "    </PPointData>\n";
    for (std::size_t i = 0; i + 1 < boundaries.size(); ++i)
        x << "    <Piece Extent=\"0 " << g.dims[0] - 1 << " 0 " << g.dims[1] - 1 << " "
          << boundaries[i] << " " << boundaries[i + 1] << "\" Source=\""
          << pieceSource(path, static_cast<int>(i)) << "\"/>\n";
    x << "  </PImageData>\n</VTKFile>\n";
    const std::string text = x.str();
    writeAtomically(path, [&](const fs::path& tmp) {
        std::ofstream out(tmp, std::ios::binary);
        out.write(text.data(), static_cast<std::streamsize>(text.size()));
        out.close();
        if (!out) UDVR_FILE_FAIL("cannot write " << path.string() << ": " << writeErrorText(errno));
    });
    // Pieces of an earlier write with more pieces, which this header no longer names.
    std::error_code ec;
    for (int i = static_cast<int>(boundaries.size()) - 1;; ++i) {
        const fs::path stale = path.parent_path() / pieceSource(path, i);
        if (!fs::remove(stale, ec)) break;
    }
}

void writeModelPvti(const fs::path& path, const ModelVolume& model, int pieces) {
    const std::vector<int> b = pvtiPieceBoundaries(model.grid.dims[2], pieces);
    // An earlier header goes first: a write stopped half-way leaves no .pvti that would name a
    // mix of old and new pieces.
    std::error_code ec;
    fs::remove(path, ec);
    for (std::size_t i = 0; i + 1 < b.size(); ++i)
        writeModelPvtiPiece(path, model, static_cast<int>(i), b[i], b[i + 1]);
    writeModelPvtiHeader(path, model, b);
}

ModelVolume readModelVti(const fs::path& path) {
    std::string note;
    ModelVolume m = detail::readModelVti(path, &note);
    detail::printNote(note);
    return m;
}

ModelVolume detail::readModelVti(const fs::path& path, std::string* geometryNote) {
    vtkSmartPointer<vtkImageData> image = readImageData(path);
    ModelVolume m;
    m.grid = gridOf(path, image, geometryNote);
    std::size_t n = m.voxelCount();
    vtkPointData* pd = image->GetPointData();
    vtkFieldData* fd = image->GetFieldData();

    // Reads array `name` with `components` per voxel (0 = any), NaN/Inf rejected.
    auto get = [&](const char* name, int components) -> std::vector<float> {
        vtkDataArray* a = pd->GetArray(name);
        if (a == nullptr) return {};
        int c = a->GetNumberOfComponents();
        if (components > 0 && c != components) {
            UDVR_FAIL(path.string() << ": array '" << name << "' has " << c
                                    << " components, expected " << components);
        }
        if (static_cast<std::size_t>(a->GetNumberOfTuples()) != n) {
            UDVR_FAIL(path.string()
                      << ": dims do not match the data: array '" << name << "' holds "
                      << a->GetNumberOfTuples() << " tuples, the grid " << n << " points");
        }
        std::vector<float> v = toFloat(path, a);
        try {
            detail::checkFinite(path, m.grid, v, c, std::string("array '") + name + "'");
        } catch (const UdvrError& e) {
            throw detail::ModelContentError(e.what());
        }
        return v;
    };
    m.mean = get("mean", 1);
    m.stddev = get("stddev", 1);
    m.min = get("min", 1);
    m.max = get("max", 1);
    m.iqr = get("iqr", 2);

    int q = getInt(path, fd, "quantile_count", 0);
    if (vtkDataArray* a = pd->GetArray("quantiles")) {
        if (q == 0) q = a->GetNumberOfComponents() - 1;
        if (q < 1) UDVR_FAIL(path.string() << ": array 'quantiles' needs at least 2 components");
        m.quantiles = get("quantiles", q + 1);
        m.quantileCount = q;
        m.quantileLevels = normalizedQuantileLevels(
            getDoubles(fd, "quantile_levels"), q, path.string() + ": field data 'quantile_levels'");
    }
    int k = getInt(path, fd, "gmm_components", 0);
    if (vtkDataArray* a = pd->GetArray("gmm")) {
        if (k == 0) k = a->GetNumberOfComponents() / 3;
        if (k < 1 || a->GetNumberOfComponents() != 3 * k) {
            UDVR_FAIL(path.string() << ": array 'gmm' has " << a->GetNumberOfComponents()
                                    << " components, expected 3K (pi, mu, sigma per component)");
        }
        m.gmm = get("gmm", 3 * k);
        m.gmmComponents = k;
    }
    if (m.mean.empty() && m.quantiles.empty() && m.gmm.empty() && m.iqr.empty() && m.min.empty()) {
        UDVR_FAIL(path.string() << ": no model arrays (mean, stddev, min, max, quantiles, iqr, "
                                   "gmm); arrays present: "
                                << arrayNames(pd));
    }

    m.density = getString(fd, "density", m.density);
    m.bandwidth = getDouble(fd, "bandwidth", 0.0);
    m.bandwidthRule = getString(fd, "bandwidth_rule", "");
    m.tailEps = getDouble(fd, "tail_eps", 0.0);
    m.samplesPerVoxel = getInt(path, fd, "samples_per_voxel", 0);
    m.downsample = getInt(path, fd, "downsample", 0);
    std::vector<double> bounds = getDoubles(fd, "bounds");
    if (bounds.empty()) {
        m.bounds = m.grid.bounds();
    } else if (bounds.size() == 6) {
        std::copy(bounds.begin(), bounds.end(), m.bounds.begin());
    } else {
        UDVR_FAIL(path.string() << ": field data 'bounds' holds " << bounds.size()
                                << " values, expected 6");
    }
    m.fullResMinSpacing = getDouble(fd, "full_res_min_spacing", m.grid.minSpacing());
    if (!(m.fullResMinSpacing > 0.0)) {
        UDVR_FAIL(path.string() << ": field data 'full_res_min_spacing' must be positive");
    }
    m.source = getString(fd, "source", "");
    try {
        checkModelArrays(m, path.string());
    } catch (const UdvrError& e) {
        throw detail::ModelContentError(e.what());
    }
    return m;
}

// ---- 2D transfer functions (SPEC §9) -----------------------------------------------------------

TransferFunction2D detail::readTransferFunction2DVti(const fs::path& path) {
    vtkSmartPointer<vtkImageData> image =
        readImageData(path, static_cast<double>(kMaxTf2Resolution) * kMaxTf2Resolution);
    const std::string name = path.string();
    int extent[6];
    double origin[3], spacing[3];
    image->GetExtent(extent);
    image->GetOrigin(origin);
    image->GetSpacing(spacing);
    const int w = extent[1] - extent[0] + 1, h = extent[3] - extent[2] + 1;
    const int d = extent[5] - extent[4] + 1;
    if (d != 1 || w < 2 || h < 2)
        UDVR_FAIL(name << ": a 2D transfer function needs W x H x 1 points with W, H >= 2, got "
                       << w << "x" << h << "x" << d);
    for (int a = 0; a < 2; ++a)
        if (!(spacing[a] > 0.0) || !std::isfinite(spacing[a]) || !std::isfinite(origin[a]))
            UDVR_FAIL(name << ": spacing along " << (a == 0 ? "x" : "y") << " is " << spacing[a]
                           << " (origin " << origin[a] << "), expected a positive number");

    // The active scalars when they are RGBA, else the first 4-component point array.
    vtkPointData* pd = image->GetPointData();
    vtkDataArray* array = pd->GetScalars();
    if (array == nullptr || array->GetNumberOfComponents() != 4) {
        array = nullptr;
        for (int i = 0; i < pd->GetNumberOfArrays() && array == nullptr; ++i) {
            vtkDataArray* a = pd->GetArray(i);
            if (a != nullptr && a->GetNumberOfComponents() == 4) array = a;
        }
    }
    if (array == nullptr)
        UDVR_FAIL(name << ": no 4-component (r, g, b, alpha) point array (arrays: "
                       << arrayNames(pd) << ")");
    const std::string arrayName = array->GetName() ? array->GetName() : "";
    if (array->GetDataType() != VTK_FLOAT && array->GetDataType() != VTK_DOUBLE)
        UDVR_FAIL(name << ": point array '" << arrayName << "' is " << array->GetDataTypeAsString()
                       << ", expected float or double");
    if (static_cast<std::size_t>(array->GetNumberOfTuples()) != static_cast<std::size_t>(w) * h)
        UDVR_FAIL(name << ": dims do not match the data: array '" << arrayName << "' holds "
                       << array->GetNumberOfTuples() << " tuples, the grid " << w * h << " points");

    TransferFunction2D tf;
    tf.width = w;
    tf.height = h;
    tf.rgba = toFloat(path, array);
    for (std::size_t k = 0; k < tf.rgba.size(); ++k)
        if (!std::isfinite(tf.rgba[k]))
            UDVR_FAIL(name << ": non-finite value in array '" << arrayName << "' at point ("
                           << k / 4 % static_cast<std::size_t>(w) << ","
                           << k / 4 / static_cast<std::size_t>(w)
                           << "); expected values in [0, 1]");
    tf.x0 = origin[0] + extent[0] * spacing[0];
    tf.x1 = tf.x0 + (w - 1) * spacing[0];
    tf.y0 = origin[1] + extent[2] * spacing[1];
    tf.y1 = tf.y0 + (h - 1) * spacing[1];
    // udvr's own files also hold the exact domain (origin + (W−1)·spacing may differ from x1 in
    // the last bits); it is used only where it agrees with the geometry.
    const std::vector<double> exact = getDoubles(image->GetFieldData(), "tf2_domain");
    if (exact.size() == 4) {
        const double tolX = 1e-6 * spacing[0], tolY = 1e-6 * spacing[1];
        if (std::abs(exact[0] - tf.x0) <= tolX && std::abs(exact[1] - tf.x1) <= tolX &&
            std::abs(exact[2] - tf.y0) <= tolY && std::abs(exact[3] - tf.y1) <= tolY) {
            tf.x0 = exact[0];
            tf.x1 = exact[1];
            tf.y0 = exact[2];
            tf.y1 = exact[3];
        }
    }
    try {
        tf.validate();
    } catch (const UdvrError& e) {
        UDVR_FAIL(name << ": " << e.what());
    }
    return tf;
}

void writeTransferFunction2DVti(const fs::path& path, const TransferFunction2D& tf) {
    tf.validate();
    auto image = vtkSmartPointer<vtkImageData>::New();
    image->SetDimensions(tf.width, tf.height, 1);
    image->SetOrigin(tf.x0, tf.y0, 0.0);
    image->SetSpacing((tf.x1 - tf.x0) / (tf.width - 1), (tf.y1 - tf.y0) / (tf.height - 1), 1.0);
    image->GetPointData()->SetScalars(wrapFloats(tf.rgba, 4, "tf2"));
    addDouble(image->GetFieldData(), "tf2_domain", {tf.x0, tf.x1, tf.y0, tf.y1});
    writeImageData(path, image);
}

std::vector<ArrayInfo> detail::listArraysVti(const fs::path& path) {
    // The header only: the reader's pipeline information names each point array, its type and
    // components without reading the data (a model's arrays can be gigabytes).
    if (detail::lowerExtension(path) == ".pvti")  // the arrays of its first piece
        return listArraysVti(readPvtiHeader(path).pieces.front().file);
    vtkNew<ErrorCollector> errors;
    auto reader = newReader(path, errors);
    reader->UpdateInformation();
    throwIfFailed(path, reader, errors, false);
    vtkInformationVector* arraysInfo =
        reader->GetOutputInformation(0)->Get(vtkDataObject::POINT_DATA_VECTOR());
    std::vector<ArrayInfo> arrays;
    for (int i = 0; arraysInfo != nullptr && i < arraysInfo->GetNumberOfInformationObjects(); ++i) {
        vtkInformation* info = arraysInfo->GetInformationObject(i);
        ArrayInfo a;
        a.name = info->Has(vtkDataObject::FIELD_NAME()) ? info->Get(vtkDataObject::FIELD_NAME())
                                                        : "(unnamed)";
        a.components = info->Has(vtkDataObject::FIELD_NUMBER_OF_COMPONENTS())
                           ? info->Get(vtkDataObject::FIELD_NUMBER_OF_COMPONENTS())
                           : 1;
        const int type = info->Get(vtkDataObject::FIELD_ARRAY_TYPE());
        if (type == VTK_STRING) continue;  // not a numeric array
        a.type = vtkTypeName(type);
        arrays.push_back(a);
    }
    return arrays;
}

ModelVolume readModelOrField(const fs::path& path, const FieldReadOptions& options) {
    const std::string ext = detail::lowerExtension(path);
    if ((ext == ".vti" || ext == ".pvti") && options.var.empty()) {
        std::string modelError;
        try {
            std::string note;
            ModelVolume m = detail::readModelVti(path, &note);
            if (!m.mean.empty()) {
                detail::printNote(note);
                return m;
            }
            modelError = path.string() + " has no 'mean' array";
        } catch (const detail::ModelContentError&) {
            throw;  // a model, with impossible values: not a field either
        } catch (const UdvrError& e) {
            modelError = e.what();
        }
        try {
            return modelFromField(readField(path, options));
        } catch (const UdvrError& e) {
            // Both readers open the file the same way: a missing, truncated or corrupt file
            // fails both for one reason, which is said once (as the error it was: a FileError
            // stays one).
            if (modelError == e.what()) throw;
            UDVR_FAIL(path.string() << " is neither a model (" << modelError << ") nor a field ("
                                    << e.what() << ")");
        }
    }
    return modelFromField(readField(path, options));
}

// ---- models, a slab at a time (out-of-core build) ----------------------------------------------

namespace {

/// An unnamed temporary file in `dir` (gone when closed, also after kill -9).
int unnamedTemporary(const fs::path& dir, const fs::path& forPath) {
#ifdef O_TMPFILE
    int fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
    if (fd >= 0) return fd;
#endif
    std::string name = (dir / ".udvr-spill-XXXXXX").string();
    fd = ::mkstemp(name.data());
    if (fd < 0)
        UDVR_FILE_FAIL("cannot write " << forPath.string() << ": a temporary file in "
                                       << dir.string() << ": " << writeErrorText(errno));
    ::unlink(name.c_str());
    return fd;
}

void writeAll(int fd, const unsigned char* data, std::size_t size, const fs::path& forPath) {
    while (size > 0) {
        const ssize_t w = ::write(fd, data, size);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0)
            UDVR_FILE_FAIL("cannot write " << forPath.string() << ": "
                                           << writeErrorText(w < 0 ? errno : ENOSPC));
        data += w;
        size -= static_cast<std::size_t>(w);
    }
}

/// `attr="value"` in the space VTK's writer reserves for it and fills in later
/// (vtkXMLWriter::ReserveAttributeSpace: ` attr=""` and 20 spaces).
std::string reservedAttribute(const char* attr, const std::string& value) {
    std::string s = std::string(" ") + attr + "=\"" + value + "\"";
    const std::size_t width = std::string(attr).size() + 4 + 20;
    if (s.size() < width) s.append(width - s.size(), ' ');
    return s;
}

/// A double as VTK's writer prints it (an ostream of precision 11).
std::string vtkDouble(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.11g", v);
    return buf;
}

}  // namespace

struct ModelVtiStreamWriter::Impl {
    struct Array {
        const char* name = "";
        int components = 1;
        const std::vector<float> ModelVolume::*member = nullptr;
        int fd = -1;
        std::vector<unsigned char> pending;     // the start of the next block
        std::vector<std::uint64_t> blockSizes;  // compressed, in order
        std::uint64_t rawBytes = 0, spillBytes = 0;
        double range[2] = {std::numeric_limits<double>::infinity(),
                           -std::numeric_limits<double>::infinity()};
    };
    fs::path path;
    Grid3 grid;
    int quantileCount = 0, gmmComponents = 0;
    std::size_t voxelsDone = 0;
    std::vector<Array> arrays;
    vtkSmartPointer<vtkXMLImageDataWriter> writer;  // the compressor and block size of the file
    std::size_t blockSize = 0;
    bool finished = false;

    ~Impl() {
        for (Array& a : arrays)
            if (a.fd >= 0) ::close(a.fd);
    }

    void compressBlock(Array& a, const unsigned char* data, std::size_t size) {
        vtkUnsignedCharArray* out = writer->GetCompressor()->Compress(data, size);
        if (out == nullptr)
            UDVR_FILE_FAIL("cannot write " << path.string() << ": compression failed");
        const auto n = static_cast<std::size_t>(out->GetNumberOfTuples());
        try {
            writeAll(a.fd, out->GetPointer(0), n, path);
        } catch (...) {
            out->Delete();
            throw;
        }
        out->Delete();
        a.blockSizes.push_back(n);
        a.spillBytes += n;
    }

    void append(Array& a, const float* values, std::size_t count) {
        const auto* bytes = reinterpret_cast<const unsigned char*>(values);
        std::size_t size = count * sizeof(float);
        a.rawBytes += size;
        if (!a.pending.empty()) {
            const std::size_t take = std::min(size, blockSize - a.pending.size());
            a.pending.insert(a.pending.end(), bytes, bytes + take);
            bytes += take;
            size -= take;
            if (a.pending.size() == blockSize) {
                compressBlock(a, a.pending.data(), blockSize);
                a.pending.clear();
            }
        }
        for (; size >= blockSize; bytes += blockSize, size -= blockSize)
            compressBlock(a, bytes, blockSize);
        a.pending.insert(a.pending.end(), bytes, bytes + size);
        // The range as the writer takes it (GetRange(-1): the values, or the tuples' L2 norm);
        // a minimum of slab minima is the minimum of the whole.
        auto wrapped = vtkSmartPointer<vtkFloatArray>::New();
        wrapped->SetNumberOfComponents(a.components);
        wrapped->SetArray(const_cast<float*>(values), static_cast<vtkIdType>(count), 1);
        const double* r = wrapped->GetRange(-1);
        a.range[0] = std::min(a.range[0], r[0]);
        a.range[1] = std::max(a.range[1], r[1]);
    }
};

ModelVtiStreamWriter::ModelVtiStreamWriter(const fs::path& path, const Grid3& grid,
                                           int quantileCount, int gmmComponents)
    : impl_(std::make_unique<Impl>()) {
    Impl& w = *impl_;
    w.path = path;
    w.grid = grid;
    w.quantileCount = quantileCount;
    w.gmmComponents = gmmComponents;
    requireWritableDirectory(path);
    silenceVtk();
    w.writer = vtkSmartPointer<vtkXMLImageDataWriter>::New();
    configureWriter(w.writer, Compression::Lz4);
    w.blockSize = static_cast<std::size_t>(w.writer->GetBlockSize());
    UDVR_CHECK(w.writer->GetCompressor() != nullptr && w.blockSize > 0);
    for (const ModelFileArray& file : kModelFileArrays) {  // writeModelVti's order
        const int c = file.floatsPerVoxel(quantileCount, gmmComponents);
        if (c == 0) continue;
        Impl::Array a;
        a.name = file.name;
        a.components = c;
        a.member = file.values;
        w.arrays.push_back(std::move(a));
    }
    fs::path dir = path.parent_path();
    if (dir.empty()) dir = ".";
    for (Impl::Array& a : w.arrays) {
        a.fd = unnamedTemporary(dir, path);
        a.pending.reserve(w.blockSize);
    }
}

ModelVtiStreamWriter::~ModelVtiStreamWriter() = default;

void ModelVtiStreamWriter::append(const ModelVolume& slab) {
    Impl& w = *impl_;
    UDVR_CHECK(!w.finished);
    const std::size_t voxels = slab.mean.size();
    UDVR_CHECK_MSG(w.voxelsDone + voxels <= w.grid.pointCount(), "model slabs beyond the grid");
    for (Impl::Array& a : w.arrays) {
        const std::vector<float>& values = slab.*(a.member);
        UDVR_CHECK_MSG(values.size() == voxels * static_cast<std::size_t>(a.components),
                       std::string("model slab array size: ") + a.name);
        w.append(a, values.data(), values.size());
    }
    w.voxelsDone += voxels;
}

void ModelVtiStreamWriter::finish(const ModelVolume& model) {
    Impl& w = *impl_;
    UDVR_CHECK(!w.finished);
    UDVR_CHECK_MSG(w.voxelsDone == w.grid.pointCount(), "model slabs do not cover the grid");
    w.finished = true;
    for (Impl::Array& a : w.arrays) {
        if (!a.pending.empty()) w.compressBlock(a, a.pending.data(), a.pending.size());
        a.pending.clear();
        a.pending.shrink_to_fit();
    }
    // The file as VTK writes it without point data: the header, the field data and their
    // appended bytes. The point arrays' lines and data are put in as VTK would have.
    auto image = makeImage(w.grid);
    addModelFieldData(image->GetFieldData(), model, w.quantileCount > 0, w.gmmComponents > 0);
    w.writer->SetInputData(image);
    w.writer->WriteToOutputStringOn();
    vtkNew<ErrorCollector> errors;
    w.writer->AddObserver(vtkCommand::ErrorEvent, errors);
    if (w.writer->Write() != 1 || errors->count > 0)
        UDVR_FILE_FAIL("cannot write " << w.path.string() << ": " << errors->message);
    const std::string skeleton = w.writer->GetOutputString();
    const std::string pdOpen = "<PointData>\n", pdClose = "</PointData>\n";
    const std::string appended = "<AppendedData encoding=\"raw\">\n   _";
    const std::string trailer = "\n  </AppendedData>\n</VTKFile>\n";
    const std::size_t p0 = skeleton.find(pdOpen);
    const std::size_t p1 = skeleton.find(pdClose, p0);
    const std::size_t a0 = skeleton.find(appended);
    UDVR_CHECK_MSG(
        p0 != std::string::npos && p1 != std::string::npos && a0 != std::string::npos &&
            skeleton.size() >= a0 + trailer.size() &&
            skeleton.compare(skeleton.size() - trailer.size(), trailer.size(), trailer) == 0,
        "VTK's model header is not as expected");
    const std::size_t lineStart = skeleton.rfind('\n', p0) + 1;
    const std::string indent(p0 - lineStart, ' ');
    const std::size_t fieldStart = a0 + appended.size();
    const std::size_t fieldBytes = skeleton.size() - trailer.size() - fieldStart;

    std::string header = skeleton.substr(0, p0);
    header += "<PointData Scalars=\"mean\">\n";
    std::uint64_t offset = fieldBytes;
    for (const Impl::Array& a : w.arrays) {
        header += indent + "  <DataArray type=\"Float32\" Name=\"" + a.name + "\"";
        if (a.components > 1)
            header += " NumberOfComponents=\"" + std::to_string(a.components) + "\"";
        header += " format=\"appended\"";
        header += reservedAttribute("RangeMin", vtkDouble(a.range[0]));
        header += reservedAttribute("RangeMax", vtkDouble(a.range[1]));
        header += reservedAttribute("offset", std::to_string(offset));
        header += "/>\n";
        offset += 8 * (3 + a.blockSizes.size()) + a.spillBytes;
    }
    header += indent + pdClose;
    header += skeleton.substr(p1 + pdClose.size(), fieldStart - (p1 + pdClose.size()));

    writeAtomically(w.path, [&](const fs::path& tmp) {
        const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (fd < 0)
            UDVR_FILE_FAIL("cannot write " << w.path.string() << ": " << writeErrorText(errno));
        struct Closer {
            int fd;
            ~Closer() {
                if (fd >= 0) ::close(fd);
            }
        } closer{fd};
        auto put = [&](const void* data, std::size_t size) {
            writeAll(fd, static_cast<const unsigned char*>(data), size, w.path);
        };
        put(header.data(), header.size());
        put(skeleton.data() + fieldStart, fieldBytes);
        std::vector<unsigned char> buf(std::size_t{4} << 20);
        for (const Impl::Array& a : w.arrays) {
            // vtkXMLWriter's compression header: blocks, block size, last block size, sizes.
            std::vector<std::uint64_t> words = {a.blockSizes.size(), w.blockSize,
                                                a.rawBytes % w.blockSize};
            words.insert(words.end(), a.blockSizes.begin(), a.blockSizes.end());
            put(words.data(), words.size() * sizeof(std::uint64_t));
            std::uint64_t left = a.spillBytes;
            for (off_t at = 0; left > 0;) {
                const ssize_t r =
                    ::pread(a.fd, buf.data(), std::min<std::uint64_t>(left, buf.size()), at);
                if (r < 0 && errno == EINTR) continue;
                if (r <= 0)
                    UDVR_FILE_FAIL("cannot write "
                                   << w.path.string() << ": reading back its " << a.name
                                   << " array: " << (r < 0 ? std::strerror(errno) : "short file"));
                put(buf.data(), static_cast<std::size_t>(r));
                at += r;
                left -= static_cast<std::uint64_t>(r);
            }
        }
        put(trailer.data(), trailer.size());
        closer.fd = -1;
        if (::close(fd) != 0)
            UDVR_FILE_FAIL("cannot write " << w.path.string() << ": " << writeErrorText(errno));
    });
    for (Impl::Array& a : w.arrays) {
        ::close(a.fd);
        a.fd = -1;
    }
}

}  // namespace udvr
