// "udvr model (.pvti)" (issue 32, docs/paraview.md): VTK's reader of partitioned image data
// (.pvti, e.g. from `mpirun … udvr build`) that keeps each rank's piece once. VTK's
// vtkXMLPImageDataReader reads the files of the requested extent through one
// vtkXMLImageDataReader per piece and copies their outputs into its own, keeping the piece
// readers' outputs as well: every rank held its piece twice (216 MiB model, 2 ranks: +216/+220
// MiB each). This reader releases the piece readers' outputs once they are copied, so a rank
// holds what it was asked for (its piece and the ghost layer) once.
#ifndef vtkUdvrPImageDataReader_h
#define vtkUdvrPImageDataReader_h

#include "UdvrParaViewModule.h"  // for export macro
#include "vtkXMLPImageDataReader.h"

class UDVRPARAVIEW_EXPORT vtkUdvrPImageDataReader : public vtkXMLPImageDataReader {
  public:
    static vtkUdvrPImageDataReader* New();
    vtkTypeMacro(vtkUdvrPImageDataReader, vtkXMLPImageDataReader);
    void PrintSelf(ostream& os, vtkIndent indent) override;

  protected:
    vtkUdvrPImageDataReader() = default;
    ~vtkUdvrPImageDataReader() override = default;
    void ReadXMLData() override;

  private:
    vtkUdvrPImageDataReader(const vtkUdvrPImageDataReader&) = delete;
    void operator=(const vtkUdvrPImageDataReader&) = delete;
};

#endif
