// udvr_fuzz_corpus: writes the seed corpora of the fuzz targets (fuzz/corpus/<target>/), small
// valid files of each form a reader takes, made by udvr's own writers, by VTK's writer in the
// modes udvr does not use (raw appended, inline base64, ascii, LZ4) and by netCDF-C (classic,
// CDF-5, NetCDF-4), plus a small piece of ../shared/data/isabel-windspeed when it is there.
//   udvr_fuzz_corpus OUT_DIR     (scripts/fuzz.sh --corpus rewrites fuzz/corpus this way)
// Deterministic: the same build writes the same bytes.
#include <netcdf.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkShortArray.h>
#include <vtkUnsignedCharArray.h>
#include <vtkXMLImageDataReader.h>
#include <vtkXMLImageDataWriter.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_target.h"
#include "udvr/classify/tf_presets.h"
#include "udvr/data/noise.h"
#include "udvr/data/synthetic.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/image.h"
#include "udvr/io/model_io.h"
#include "udvr/io/npy.h"
#include "udvr/io/transfer_function_2d_io.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/stats/build_model.h"

namespace fs = std::filesystem;
using namespace udvr;

namespace {

fs::path gOut;

std::string readFile(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void put(const std::string& target, const std::string& name, const std::string& bytes) {
    fs::create_directories(gOut / target);
    std::ofstream out(gOut / target / name, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) throw std::runtime_error("cannot write " + (gOut / target / name).string());
}

/// The bytes a writer leaves in a temporary file.
std::string viaFile(const std::string& name, const std::function<void(const fs::path&)>& write) {
    const fs::path p = fuzz::Scratch::get().path(name);
    write(p);
    std::string bytes = readFile(p);
    fs::remove(p);
    return bytes;
}

template <class T>
std::string bytesOf(const std::vector<T>& v, bool bigEndian = false) {
    std::string s;
    for (T x : v) {
        char b[sizeof(T)];
        std::memcpy(b, &x, sizeof(T));
        if (bigEndian) std::reverse(b, b + sizeof(T));
        s.append(b, sizeof(T));
    }
    return s;
}

std::string gzip(const std::string& data) {
    z_stream zs{};
    deflateInit2(&zs, 9, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
    std::string out(deflateBound(&zs, static_cast<uLong>(data.size())) + 32, '\0');
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
    zs.avail_in = static_cast<uInt>(data.size());
    zs.next_out = reinterpret_cast<Bytef*>(out.data());
    zs.avail_out = static_cast<uInt>(out.size());
    deflate(&zs, Z_FINISH);
    out.resize(zs.total_out);
    deflateEnd(&zs);
    return out;
}

const std::string kSep(fuzz::kPartSeparator);

ScalarField tangle(int nx, int ny, int nz) { return makeTangle(nx, ny, nz); }

// ---- raw and NRRD ------------------------------------------------------------------------------

void rawSeeds() {
    // Layout byte (raw_fuzz.cpp): bits 0-3 type, bit 4 big-endian, bit 5 int32 dims, bit 6
    // spacing and origin; small dims are 1 + b % 16.
    const ScalarField f = tangle(4, 3, 2);
    std::vector<float> v = f.values;
    put("raw", "float32-4x3x2", std::string("\x06\x03\x02\x01", 4) + bytesOf(v));
    std::vector<std::uint8_t> u8(24);
    for (std::size_t i = 0; i < u8.size(); ++i) u8[i] = static_cast<std::uint8_t>(i * 10);
    put("raw", "uint8-4x3x2", std::string("\x00\x03\x02\x01", 4) + bytesOf(u8));
    std::vector<std::int16_t> i16(24);
    for (std::size_t i = 0; i < i16.size(); ++i) i16[i] = static_cast<std::int16_t>(i * 100 - 999);
    put("raw", "int16-be-4x3x2", std::string("\x13\x03\x02\x01", 4) + bytesOf(i16, true));
    std::vector<double> f64(v.begin(), v.end());
    std::string layout("\x47\x03\x02\x01", 4);
    layout += bytesOf(std::vector<double>{0.5, 0.5, 2.0, -1.0, 0.0, 10.0});
    put("raw", "float64-spacing-4x3x2", layout + bytesOf(f64));
    std::string big("\x26", 1);
    big += bytesOf(std::vector<std::int32_t>{2, 2, 2});
    put("raw", "float32-int32-dims-2x2x2", big + bytesOf(std::vector<float>(8, 1.5f)));
    // A cube of another size than asked: the reader's hint names the layout that fits.
    put("raw", "float32-size-hint", std::string("\x06\x01\x01\x01", 4) + bytesOf(v) + bytesOf(v));
}

std::string nrrdHeader(const std::string& type, const std::string& encoding,
                       const std::string& extra) {
    return "NRRD0004\n# udvr fuzz seed\ntype: " + type + "\ndimension: 3\nsizes: 4 3 2\n" + extra +
           "encoding: " + encoding + "\n";
}

void nrrdSeeds() {
    const ScalarField f = tangle(4, 3, 2);
    const std::string data = bytesOf(f.values);
    put("nrrd", "attached-raw.nrrd",
        nrrdHeader("float", "raw", "spacings: 1 1 2\nendian: little\n") + "\n" + data);
    put("nrrd", "attached-gzip.nrrd",
        nrrdHeader("float", "gzip", "endian: little\nspace origin: (1,2,3)\n") + "\n" + gzip(data));
    std::string ascii;
    for (float x : f.values) ascii += std::to_string(x) + " ";
    put("nrrd", "attached-ascii.nrrd",
        nrrdHeader("double", "ascii", "content: tangle\n") + "\n" + ascii + "\n");
    std::vector<std::uint16_t> u16(24);
    for (std::size_t i = 0; i < u16.size(); ++i) u16[i] = static_cast<std::uint16_t>(i * 1000);
    put("nrrd", "attached-uint16-be-directions.nrrd",
        nrrdHeader("unsigned short", "raw",
                   "space: right-anterior-superior\nspace directions: (0.5,0,0) (0,0.5,0) "
                   "(0,0,2)\nspace origin: (0,0,-4)\nendian: big\nkinds: domain domain "
                   "domain\n") +
            "\n" + bytesOf(u16, true));
    put("nrrd", "detached-raw.nhdr",
        nrrdHeader("float", "raw", "spacings: 1 1 1\nendian: little\n") + "data file: data.raw\n" +
            kSep + data);
    put("nrrd", "detached-gzip.nhdr",
        nrrdHeader("float", "gz", "endian: little\n") + "data file: data.raw\n" + kSep +
            gzip(data));
    std::vector<std::uint8_t> u8(24, 7);
    put("nrrd", "detached-skips.nhdr",
        nrrdHeader("uchar", "raw", "line skip: 1\nbyte skip: -1\n") + "datafile: data.raw\n" +
            kSep + "a comment line\n" + bytesOf(u8));
    put("nrrd", "attached-int8-byteskip.nrrd",
        nrrdHeader("int8", "raw", "byte skip: 2\nkey:=value\n") + "\nxx" + bytesOf(u8));
}

// ---- VTK XML ImageData -----------------------------------------------------------------------

enum class Mode { Appended, AppendedBase64, Binary, Ascii };
enum class Compress { None, Zlib, Lz4 };

std::string vtkBytes(vtkImageData* image, Mode mode, Compress compress, bool header64) {
    return viaFile("seed.vti", [&](const fs::path& p) {
        vtkNew<vtkXMLImageDataWriter> w;
        w->SetFileName(p.c_str());
        w->SetInputData(image);
        if (mode == Mode::Ascii) {
            w->SetDataModeToAscii();
        } else if (mode == Mode::Binary) {
            w->SetDataModeToBinary();
        } else {
            w->SetDataModeToAppended();
            w->SetEncodeAppendedData(mode == Mode::AppendedBase64 ? 1 : 0);
        }
        if (compress == Compress::None)
            w->SetCompressorTypeToNone();
        else if (compress == Compress::Zlib)
            w->SetCompressorTypeToZLib();
        else
            w->SetCompressorTypeToLZ4();
        if (header64)
            w->SetHeaderTypeToUInt64();
        else
            w->SetHeaderTypeToUInt32();
        if (w->Write() != 1) throw std::runtime_error("VTK write failed");
    });
}

vtkNew<vtkImageData> smallImage(int type) {
    vtkNew<vtkImageData> image;
    image->SetDimensions(4, 3, 2);
    image->SetOrigin(-1.0, 0.5, 2.0);
    image->SetSpacing(0.5, 1.0, 2.0);
    const ScalarField f = tangle(4, 3, 2);
    if (type == VTK_FLOAT) {
        vtkNew<vtkFloatArray> a;
        a->SetName("tangle");
        for (float x : f.values) a->InsertNextValue(x);
        image->GetPointData()->SetScalars(a);
    } else if (type == VTK_DOUBLE) {
        vtkNew<vtkDoubleArray> a;
        a->SetName("value");
        for (float x : f.values) a->InsertNextValue(x);
        image->GetPointData()->SetScalars(a);
    } else if (type == VTK_SHORT) {
        vtkNew<vtkShortArray> a;
        a->SetName("counts");
        for (float x : f.values) a->InsertNextValue(static_cast<short>(std::lround(x * 100)));
        image->GetPointData()->SetScalars(a);
    } else {
        vtkNew<vtkUnsignedCharArray> a;
        a->SetName("bytes");
        for (float x : f.values)
            a->InsertNextValue(static_cast<unsigned char>(std::lround(std::abs(x)) % 256));
        image->GetPointData()->SetScalars(a);
    }
    return image;
}

/// A 5×5×3 piece of Hurricane Isabel's wind speed as TTK wrote it (Float64, raw appended, field
/// data), when ../shared/data is there.
void isabelSeed(const fs::path& shared) {
    const fs::path src = shared / "isabel-windspeed" / "windspeed_t02.vti";
    if (!fs::exists(src)) {
        std::fprintf(stderr, "udvr_fuzz_corpus: %s absent; no Isabel seed\n", src.c_str());
        return;
    }
    vtkNew<vtkXMLImageDataReader> r;
    r->SetFileName(src.c_str());
    r->Update();
    vtkImageData* full = r->GetOutput();
    vtkNew<vtkImageData> piece;
    piece->SetDimensions(5, 5, 3);
    piece->SetOrigin(full->GetOrigin());
    piece->SetSpacing(full->GetSpacing());
    piece->GetFieldData()->ShallowCopy(full->GetFieldData());
    vtkDataArray* in = full->GetPointData()->GetScalars();
    vtkNew<vtkDoubleArray> out;
    out->SetName(in->GetName());
    int dims[3];
    full->GetDimensions(dims);
    for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 5; ++j)
            for (int i = 0; i < 5; ++i)
                out->InsertNextValue(
                    in->GetComponent(60 + i + dims[0] * (60 + j + dims[1] * (10 + k)), 0));
    piece->GetPointData()->SetScalars(out);
    put("vti", "isabel-piece-appended-raw.vti",
        vtkBytes(piece, Mode::Appended, Compress::None, true));
}

void vtiSeeds(const fs::path& shared) {
    const ScalarField f = tangle(4, 3, 2);
    put("vti", "udvr-zlib.vti", viaFile("f.vti", [&](const fs::path& p) { writeFieldVti(p, f); }));
    put("vti", "appended-raw-uint32-header.vti",
        vtkBytes(smallImage(VTK_FLOAT), Mode::Appended, Compress::None, false));
    put("vti", "appended-lz4-float64.vti",
        vtkBytes(smallImage(VTK_DOUBLE), Mode::Appended, Compress::Lz4, true));
    put("vti", "appended-base64-zlib-int16.vti",
        vtkBytes(smallImage(VTK_SHORT), Mode::AppendedBase64, Compress::Zlib, true));
    put("vti", "inline-base64-uint8.vti",
        vtkBytes(smallImage(VTK_UNSIGNED_CHAR), Mode::Binary, Compress::None, false));
    put("vti", "inline-base64-zlib.vti",
        vtkBytes(smallImage(VTK_FLOAT), Mode::Binary, Compress::Zlib, true));
    put("vti", "ascii.vti", vtkBytes(smallImage(VTK_DOUBLE), Mode::Ascii, Compress::None, true));
    isabelSeed(shared);
}

// ---- models ------------------------------------------------------------------------------------

Ensemble smallEnsemble(int members, std::uint64_t seed) {
    NoiseParams noise;
    noise.seed = seed;
    return perturbField(tangle(4, 4, 3), members, noise);
}

void modelSeeds() {
    const auto model = [](const std::string& name, const ModelVolume& m) {
        put("model", name, viaFile("m.vti", [&](const fs::path& p) { writeModelVti(p, m); }));
    };
    BuildOptions o;
    o.quantiles = 4;
    o.gmmComponents = 2;
    o.source = "fuzz seed";
    model("ensemble-q4-gmm2.vti", buildModel(smallEnsemble(6, 1), o));
    BuildOptions kde = o;
    kde.density = DensityEstimate::Kde;
    kde.gmmComponents = 0;
    kde.quantileLevels = {0.0, 0.1, 0.5, 0.9, 1.0};
    model("ensemble-kde-levels.vti", buildModel(smallEnsemble(5, 2), kde));
    BuildOptions bricks;
    bricks.quantiles = 2;
    bricks.gmmComponents = 1;
    model("bricks-k2.vti", buildModelDownsampled(tangle(6, 4, 4), 2, bricks));
    // A plain field: render and probe read it as a mean-only model.
    put("model", "field.vti",
        viaFile("f.vti", [&](const fs::path& p) { writeFieldVti(p, tangle(3, 3, 2)); }));
}

// ---- NetCDF ------------------------------------------------------------------------------------

#define NC(call)                                                                   \
    do {                                                                           \
        if (int s_ = (call); s_ != NC_NOERR)                                       \
            throw std::runtime_error(std::string(#call) + ": " + nc_strerror(s_)); \
    } while (0)

/// A NetCDF file of `format` (NC_NETCDF4, NC_CLASSIC_MODEL, NC_64BIT_DATA, 0 = CDF-1) with a
/// short variable v(z,y,x) packed with scale_factor/add_offset, optional coordinates.
std::string netcdfBytes(int format, bool coords, bool member) {
    return viaFile("seed.nc", [&](const fs::path& p) {
        int nc = -1;
        NC(nc_create(p.c_str(), NC_CLOBBER | format, &nc));
        std::vector<int> dims;
        int d = -1;
        if (member) {
            NC(nc_def_dim(nc, "ensemble", 3, &d));
            dims.push_back(d);
        }
        const char* names[3] = {"z", "y", "x"};
        const std::size_t lens[3] = {2, 3, 4};
        int axis[3];
        for (int a = 0; a < 3; ++a) {
            NC(nc_def_dim(nc, names[a], lens[a], &axis[a]));
            dims.push_back(axis[a]);
        }
        int coordIds[3];
        if (coords)
            for (int a = 0; a < 3; ++a)
                NC(nc_def_var(nc, names[a], NC_FLOAT, 1, &axis[a], &coordIds[a]));
        int v = -1;
        NC(nc_def_var(nc, "v", NC_SHORT, static_cast<int>(dims.size()), dims.data(), &v));
        const double scale = 0.01, offset = 5.0;
        const short fill = -32768;
        NC(nc_put_att_double(nc, v, "scale_factor", NC_DOUBLE, 1, &scale));
        NC(nc_put_att_double(nc, v, "add_offset", NC_DOUBLE, 1, &offset));
        NC(nc_put_att_short(nc, v, "_FillValue", NC_SHORT, 1, &fill));
        NC(nc_enddef(nc));
        if (coords)
            for (int a = 0; a < 3; ++a) {
                std::vector<float> c(lens[a]);
                for (std::size_t i = 0; i < c.size(); ++i)
                    c[i] = 10.0f + 0.5f * static_cast<float>(i);
                NC(nc_put_var_float(nc, coordIds[a], c.data()));
            }
        std::vector<short> values((member ? 3 : 1) * 24);
        for (std::size_t i = 0; i < values.size(); ++i)
            values[i] = static_cast<short>(i * 37 % 500);
        NC(nc_put_var_short(nc, v, values.data()));
        NC(nc_close(nc));
    });
}

void netcdfSeeds() {
    const ScalarField f = tangle(4, 3, 2);
    put("netcdf", "udvr-field-64bit-offset.nc",
        viaFile("f.nc", [&](const fs::path& p) { writeFieldNetcdf(p, f); }));
    put("netcdf", "udvr-ensemble-64bit-offset.nc", viaFile("e.nc", [&](const fs::path& p) {
            writeEnsembleNetcdf(p, perturbField(tangle(3, 3, 2), 3, NoiseParams{}));
        }));
    put("netcdf", "cdf1-packed-no-coords.nc", netcdfBytes(0, false, false));
    put("netcdf", "cdf5-packed-coords.nc", netcdfBytes(NC_64BIT_DATA, true, false));
    put("netcdf", "netcdf4-packed-coords.nc", netcdfBytes(NC_NETCDF4, true, false));
    put("netcdf", "netcdf4-ensemble.nc", netcdfBytes(NC_NETCDF4, true, true));
    put("netcdf", "netcdf4-classic-ensemble.nc",
        netcdfBytes(NC_NETCDF4 | NC_CLASSIC_MODEL, false, true));
}

// ---- ensembles of member files ---------------------------------------------------------------

void ensembleSeeds() {
    const Ensemble e = smallEnsemble(3, 3);
    const auto members = [&](const std::function<std::string(const ScalarField&)>& bytes) {
        std::string all;
        for (int m = 0; m < e.members; ++m) {
            ScalarField f;
            f.grid = e.grid;
            f.values.assign(e.member(m), e.member(m) + e.grid.pointCount());
            all += (m ? kSep : "") + bytes(f);
        }
        return all;
    };
    const auto nrrd = [](const ScalarField& f) {
        return "NRRD0004\ntype: float\ndimension: 3\nsizes: " + std::to_string(f.grid.dims[0]) +
               " " + std::to_string(f.grid.dims[1]) + " " + std::to_string(f.grid.dims[2]) +
               "\nendian: little\nencoding: raw\n\n" + bytesOf(f.values);
    };
    const auto vti = [](const ScalarField& f) {
        return viaFile("m.vti", [&](const fs::path& p) { writeFieldVti(p, f); });
    };
    const auto nc = [](const ScalarField& f) {
        return viaFile("m.nc", [&](const fs::path& p) { writeFieldNetcdf(p, f); });
    };
    const auto raw = [](const ScalarField& f) { return bytesOf(f.values); };
    // Byte 0 (ensemble_fuzz.cpp): bits 0-1 format, bit 2 voxel-major, bit 3 glob; raw dims.
    put("ensemble", "nrrd-list", std::string(1, '\0') + members(nrrd));
    put("ensemble", "vti-glob-voxel-major", "\x0d" + members(vti));
    put("ensemble", "raw-4x4x3", std::string("\x02\x03\x03\x02", 4) + members(raw));
    put("ensemble", "netcdf-list", "\x03" + members(nc));
}

// ---- transfer functions, .npy, images ----------------------------------------------------------

void tfSeeds() {
    put("tf_json", "tangle.json", transferFunctionToJson(tangleTransferFunction(), "tangle"));
    put("tf_json", "bare-object-no-points.json",
        R"({"ColorSpace": "Lab", "RGBPoints": [0, 0, 0, 1, 0.5, 1, 1, 1, 1, 1, 0, 0]})");
    put("tf_json", "paraview-preset.json",
        R"([{"Name": "Preset", "Creator": "ParaView", "ColorSpace": "RGB", "NanColor": [1, 1, 0],
  "Points": [0, 0, 0.5, 0, 10, 0.8, 0.25, 0.5, 20, 1, 0.5, 0],
  "RGBPoints": [0, 0.23, 0.3, 0.75, 10, 0.86, 0.86, 0.86, 20, 0.7, 0.016, 0.15]}])");

    const std::string widgets = R"({
  "domain": [0, 10, 0, 4], "resolution": [16, 8], "name": "seed",
  "widgets": [
    {"type": "box", "rgba": [1, 0, 0, 0.5], "x": [1, 3], "y": [0, 2]},
    {"type": "triangle", "rgba": [0, 1, 0, 0.4], "apex": [5, 0], "top": 3, "width": 2,
     "falloff": "flat"},
    {"type": "ellipse", "rgba": [0, 0, 1, 0.3], "center": [7, 2], "sigma": [1, 0.5],
     "angle": 30, "cutoff": 2},
    {"type": "band", "rgba": [1, 1, 0, 0.2], "points": [[0, 1], [5, 2], [10, 1]],
     "half_width": [0.5, 0.25], "profile": "tent", "comment": "c"}
  ]
})";
    put("tf2_json", "all-widgets.json", widgets);
    put("tf2_json", "box-default-resolution.json",
        R"({"domain": [-1, 1, 0, 1], "widgets": [{"type": "box", "rgba": [0.5, 0.5, 0.5, 1],
  "x": [-0.5, 0.5], "y": [0.25, 0.75]}]})");

    Tf2ReadOptions small;
    small.resolution = std::array<int, 2>{5, 4};
    const TransferFunction2D tf = transferFunction2DFromWidgets(widgets, "seed", small);
    put("tf2_vti", "udvr-5x4.vti",
        viaFile("t.vti", [&](const fs::path& p) { writeTransferFunction2DVti(p, tf); }));
    vtkNew<vtkImageData> raster;
    raster->SetDimensions(3, 2, 1);
    raster->SetOrigin(0.0, -1.0, 0.0);
    raster->SetSpacing(0.5, 2.0, 1.0);
    vtkNew<vtkDoubleArray> rgba;
    rgba->SetName("rgba");
    rgba->SetNumberOfComponents(4);
    for (int i = 0; i < 6 * 4; ++i) rgba->InsertNextValue((i % 5) / 4.0);
    raster->GetPointData()->AddArray(rgba);
    put("tf2_vti", "double-rgba-not-active.vti",
        vtkBytes(raster, Mode::Appended, Compress::None, false));

    put("npy", "tf2-5x4.npy",
        viaFile("t.npy", [&](const fs::path& p) { writeTransferFunction2DNpy(p, tf); }));
    ImageRgba image;
    image.width = 3;
    image.height = 2;
    for (int i = 0; i < 24; ++i) image.rgba.push_back(static_cast<float>(i % 7) / 6.0f);
    put("npy", "image-3x2.npy",
        viaFile("i.npy", [&](const fs::path& p) { writeFloatImage(p, image); }));
    std::vector<std::uint8_t> u8(2 * 3 * 4, 200);
    // Version 2.0: the header length in 4 bytes.
    const std::string dict = npyHeaderBytes("|u1", {2, 3, 4}).substr(10);
    put("npy", "uint8-v2-header.npy",
        std::string("\x93NUMPY\x02\x00", 8) +
            bytesOf(std::vector<std::uint32_t>{static_cast<std::uint32_t>(dict.size())}) + dict +
            bytesOf(u8));
    std::vector<double> f8(2 * 2 * 3, 0.25);
    put("npy", "float64-rgb.npy", npyHeaderBytes("<f8", {2, 2, 3}) + bytesOf(f8));

    put("image", "udvr-3x2.png", viaFile("i.png", [&](const fs::path& p) { writePng(p, image); }));
    put("image", "udvr-3x2.pfm",
        viaFile("i.pfm", [&](const fs::path& p) { writeFloatImage(p, image); }));
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: udvr_fuzz_corpus OUT_DIR\n");
        return 2;
    }
    gOut = argv[1];
    try {
        rawSeeds();
        nrrdSeeds();
        vtiSeeds(UDVR_SHARED_DATA_DIR);
        modelSeeds();
        netcdfSeeds();
        ensembleSeeds();
        tfSeeds();
    } catch (const std::exception& e) {
        std::fprintf(stderr, "udvr_fuzz_corpus: %s\n", e.what());
        return 1;
    }
    return 0;
}
