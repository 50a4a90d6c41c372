// Placeholders so the tree links while the io issue is in progress. Delete each function as
// its real implementation lands.
#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/image.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/util/check.h"

namespace udvr {
ScalarField readField(const std::filesystem::path&, const FieldReadOptions&) { UDVR_FAIL("readField: not implemented"); }
void writeFieldVti(const std::filesystem::path&, const ScalarField&) { UDVR_FAIL("not implemented"); }
void writeFieldNetcdf(const std::filesystem::path&, const ScalarField&) { UDVR_FAIL("not implemented"); }
void writeField(const std::filesystem::path&, const ScalarField&) { UDVR_FAIL("not implemented"); }
Ensemble readEnsemble(const std::vector<std::string>&, const EnsembleReadOptions&) { UDVR_FAIL("not implemented"); }
void writeEnsembleNetcdf(const std::filesystem::path&, const Ensemble&) { UDVR_FAIL("not implemented"); }
void writeModelVti(const std::filesystem::path&, const ModelVolume&) { UDVR_FAIL("not implemented"); }
ModelVolume readModelVti(const std::filesystem::path&) { UDVR_FAIL("not implemented"); }
void writePng(const std::filesystem::path&, const ImageRgba&) { UDVR_FAIL("not implemented"); }
ImageRgba readPng(const std::filesystem::path&) { UDVR_FAIL("not implemented"); }
void writeFloatImage(const std::filesystem::path&, const ImageRgba&) { UDVR_FAIL("not implemented"); }
ImageRgba readFloatImage(const std::filesystem::path&) { UDVR_FAIL("not implemented"); }
ImageRgba readImage(const std::filesystem::path&) { UDVR_FAIL("not implemented"); }
}  // namespace udvr
