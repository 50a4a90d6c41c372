#include "vtkUdvrPImageDataReader.h"

#include <cstdio>
#include <cstdlib>

#include "vtkDataObject.h"
#include "vtkImageData.h"
#include "vtkObjectFactory.h"
#include "vtkXMLDataReader.h"

vtkStandardNewMacro(vtkUdvrPImageDataReader);

void vtkUdvrPImageDataReader::ReadXMLData() {
    this->Superclass::ReadXMLData();  // copies the requested extent out of the piece readers
    const bool verbose = std::getenv("UDVR_PARAVIEW_VERBOSE") != nullptr;
    int read = 0;
    for (int i = 0; i < this->NumberOfPieces; ++i) {
        vtkXMLDataReader* piece = this->PieceReaders ? this->PieceReaders[i] : nullptr;
        vtkDataObject* data = piece ? piece->GetOutputDataObject(0) : nullptr;
        if (!data) continue;
        auto* image = vtkImageData::SafeDownCast(data);
        if (image && image->GetNumberOfPoints() > 0) ++read;
        // The copy in this reader's output is the one passed on; the piece's goes. Modified():
        // the piece reader reads its file again when this reader next needs it.
        data->Initialize();
        piece->Modified();
    }
    if (verbose) {
        int extent[6];
        this->GetOutput()->GetExtent(extent);
        std::fprintf(stderr,
                     "udvr: .pvti reader: extent %d..%d %d..%d %d..%d from %d of %d piece "
                     "file(s); the piece readers' copies released\n",
                     extent[0], extent[1], extent[2], extent[3], extent[4], extent[5], read,
                     this->NumberOfPieces);
    }
}

void vtkUdvrPImageDataReader::PrintSelf(ostream& os, vtkIndent indent) {
    this->Superclass::PrintSelf(os, indent);
}
