#pragma once
// Internal to the io module (vti_io.cpp): VTK's XML ImageData reader with the checks of what it
// trusts in a file. VTK 9.1 crashes (null dereference, division by zero) or allocates whatever a
// header asks for on some malformed files: an unknown DataArray type ("Float-7"), a compressed
// block size of 0, a block count of 2^60, an extent of 10^15 points (found by fuzzing,
// docs/testing.md). CheckedVtiReader checks the parsed XML and the data block headers before
// VTK acts on them and stops the read with problem() naming what is wrong.
#include <vtkXMLImageDataReader.h>

#include <cstdint>
#include <filesystem>
#include <string>

class vtkXMLDataElement;

namespace udvr::detail {

/// How deep elements of a VTK XML file may nest. VTK's files nest 7 deep (VTKFile, ImageData,
/// Piece, PointData, DataArray, InformationKey, Value); VTK's XML parser and element tree recurse
/// per level, and 150,000 nested elements (a 1 MB file) overflowed the stack (issue 34).
inline constexpr int kMaxXmlDepth = 256;

/// What is wrong with the nesting of the XML in `path` ("" when nothing): deeper than maxDepth
/// ("XML elements nested deeper than 256 (at byte 4242)"). A scan of the markup, without
/// building anything: tags, comments, processing instructions, CDATA and quoted attribute values
/// are told apart; it stops at <AppendedData> (raw bytes follow). Run before any XML parser sees
/// the file.
std::string xmlNestingProblem(const std::filesystem::path& path, int maxDepth = kMaxXmlDepth);

class CheckedVtiReader : public vtkXMLImageDataReader {
  public:
    static CheckedVtiReader* New();
    vtkTypeMacro(CheckedVtiReader, vtkXMLImageDataReader);

    /// What the checks found wrong ("" when nothing): one line, without the file name.
    const std::string& problem() const { return problem_; }

  protected:
    CheckedVtiReader() = default;
    /// Checks the whole parsed file, then lets VTK read it (or returns 0 with problem() set).
    int ReadVTKFile(vtkXMLDataElement* root) override;

  private:
    std::string problem_;
};

}  // namespace udvr::detail
