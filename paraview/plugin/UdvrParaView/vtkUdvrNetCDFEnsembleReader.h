// "udvr NetCDF Ensemble Reader" (issue 32, docs/paraview.md): an ensemble in one NetCDF file, a
// variable with a member dimension and three grid dimensions — `var(member, z, y, x)` as
// `udvr perturb` writes it, the layout `udvr build e.nc` reads — as image data with one
// one-component point array per member ("<var>_000", "<var>_001", … in member order), the
// input "udvr Build Model" takes. ParaView 5.11's NetCDF readers reject such a variable ("More
// than 3 dims without time not supported"). The rules are `udvr build`'s: the member dimension
// is named member, ensemble, realization or number; the grid's geometry comes from evenly
// spaced CF coordinate variables (origin 0, spacing 1 where absent); CF packing (scale_factor,
// add_offset) applies; fill values, non-finite values and a file shorter than its header says
// are errors. Reads only the requested extent, so under MPI each rank reads its piece.
// Through netCDF-C (the library ParaView's own NetCDF readers link, VTK::netcdf).
#ifndef vtkUdvrNetCDFEnsembleReader_h
#define vtkUdvrNetCDFEnsembleReader_h

#include <string>

#include "UdvrParaViewModule.h"  // for export macro
#include "vtkImageAlgorithm.h"

class UDVRPARAVIEW_EXPORT vtkUdvrNetCDFEnsembleReader : public vtkImageAlgorithm {
  public:
    static vtkUdvrNetCDFEnsembleReader* New();
    vtkTypeMacro(vtkUdvrNetCDFEnsembleReader, vtkImageAlgorithm);
    void PrintSelf(ostream& os, vtkIndent indent) override;

    vtkSetStdStringFromCharMacro(FileName);
    vtkGetCharFromStdStringMacro(FileName);
    /// 1 when FileName is a NetCDF file with a variable udvr reads as an ensemble (for
    /// ParaView's reader factory).
    int CanReadFile(const char* fileName);

  protected:
    vtkUdvrNetCDFEnsembleReader();
    ~vtkUdvrNetCDFEnsembleReader() override = default;
    int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
    int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

    std::string FileName;

  private:
    vtkUdvrNetCDFEnsembleReader(const vtkUdvrNetCDFEnsembleReader&) = delete;
    void operator=(const vtkUdvrNetCDFEnsembleReader&) = delete;
};

#endif
