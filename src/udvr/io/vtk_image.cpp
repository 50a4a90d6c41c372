// VTK plumbing of the .vti readers and writers (vtk_image.h).
#include "udvr/io/vtk_image.h"

#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkErrorCode.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkIntArray.h>
#include <vtkLogger.h>
#include <vtkMatrix3x3.h>
#include <vtkNew.h>
#include <vtkOutputWindow.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkStringArray.h>
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

namespace udvr::vtkio {

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
static void requireXmlNesting(const fs::path& path) {
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

static vtkSmartPointer<vtkImageData> readPvti(const fs::path& path, double maxPoints);

/// Read a VTK ImageData file (.vti, or a .pvti and its pieces as one image); with maxPoints > 0,
/// a whole extent of more points is refused from the header, before any data is allocated.
vtkSmartPointer<vtkImageData> readImageData(const fs::path& path, double maxPoints) {
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
static std::vector<long long> intsOf(const fs::path& path, vtkXMLDataElement* e, const char* name,
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

static std::array<double, 3> doublesOf(const fs::path& path, vtkXMLDataElement* e,
                                       const char* name) {
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
static vtkSmartPointer<vtkImageData> readPvti(const fs::path& path, double maxPoints) {
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
static void convertValues(const T* src, std::size_t n, float* dst) {
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

/// Binary appended, block-compressed, 64-bit headers: ParaView's default kind of .vti.
void configureWriter(vtkXMLImageDataWriter* writer, Compression compression) {
    writer->SetDataModeToAppended();
    writer->EncodeAppendedDataOff();
    if (compression == Compression::Lz4)
        writer->SetCompressorTypeToLZ4();
    else if (compression == Compression::None)
        writer->SetCompressorTypeToNone();
    else
        writer->SetCompressorTypeToZLib();
    writer->SetHeaderTypeToUInt64();
}

/// Write `image` as configureWriter says, atomically.
void writeImageData(const fs::path& path, vtkImageData* image, Compression compression) {
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

}  // namespace udvr::vtkio
