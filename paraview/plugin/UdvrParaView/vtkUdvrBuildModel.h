// "udvr Build Model" (issue 32, docs/paraview.md): a udvr model (SPEC §7 arrays and field data)
// from an ensemble whose members are the one-component point arrays of an image — `udvr build`
// over member files — or, with Downsample K ≥ 2, from the K³ bricks of one array (`udvr build
// FIELD --downsample K`); `udvr build`'s model options are properties (the same BuildOptions).
// Every voxel's model depends on its own samples, its index in the whole grid (the GMM's random
// stream) and the whole ensemble's data range (the GMM's σ floor) only, so under MPI each rank
// builds its own piece of whole x-y planes, with the ranks' range reduced over MPI: `udvr build`'s
// model.
#ifndef vtkUdvrBuildModel_h
#define vtkUdvrBuildModel_h

#include <string>

#include "UdvrParaViewModule.h"  // for export macro
#include "vtkImageAlgorithm.h"

class UDVRPARAVIEW_EXPORT vtkUdvrBuildModel : public vtkImageAlgorithm {
  public:
    static vtkUdvrBuildModel* New();
    vtkTypeMacro(vtkUdvrBuildModel, vtkImageAlgorithm);
    void PrintSelf(ostream& os, vtkIndent indent) override;

    /// q quantiles (0 skips the quantiles array), `udvr build --quantiles`.
    vtkSetClampMacro(Quantiles, int, 0, 1024);
    vtkGetMacro(Quantiles, int);
    /// K GMM components (0 skips), `--gmm`; lowered to the member count when there are fewer.
    vtkSetClampMacro(GmmComponents, int, 0, 64);
    vtkGetMacro(GmmComponents, int);
    /// -1 udvr build's default (kde with Downsample, else empirical), 0 empirical, 1 kde,
    /// 2 dequantized (integer-typed arrays only), `--density`.
    vtkSetClampMacro(Density, int, -1, 2);
    vtkGetMacro(Density, int);
    /// K ≥ 2: model the K³ bricks of one array (the one selected as input array 0, ParaView's
    /// SelectInputScalars), `--downsample K`; 0: the point arrays are an ensemble's members.
    vtkSetClampMacro(Downsample, int, 0, 1024);
    vtkGetMacro(Downsample, int);
    /// kde bandwidth "silverman" | "scott" | h in data units, `--bandwidth`.
    vtkSetStdStringFromCharMacro(Bandwidth);
    vtkGetCharFromStdStringMacro(Bandwidth);
    /// kde tail probability of b_0 and b_q; 0: 1/(2n), `--tail-eps`.
    vtkSetMacro(TailEps, double);
    vtkGetMacro(TailEps, double);
    /// "t_0,…,t_q": uneven quantile levels (q from their count, over Quantiles),
    /// `--quantile-levels`.
    vtkSetStdStringFromCharMacro(QuantileLevels);
    vtkGetCharFromStdStringMacro(QuantileLevels);
    /// 0 error, 1 skip: NaN/Inf samples, `--nan`.
    vtkSetClampMacro(NanPolicy, int, 0, 1);
    vtkGetMacro(NanPolicy, int);

  protected:
    vtkUdvrBuildModel() = default;
    ~vtkUdvrBuildModel() override = default;
    /// The input of whole x-y planes over the z-range asked for (with Downsample K, the K
    /// input planes of each model plane): the piece's voxels then have consecutive indices in
    /// the whole grid, which the GMM's random streams are keyed by.
    /// With Downsample K: the reduced grid (⌊N/K⌋ points per axis at brick centres, SPEC §2).
    int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
    int RequestUpdateExtent(vtkInformation*, vtkInformationVector**,
                            vtkInformationVector*) override;
    int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

    int Quantiles = 8;
    int GmmComponents = 4;
    int Density = -1;
    int Downsample = 0;
    std::string Bandwidth = "silverman";
    double TailEps = 0.0;
    std::string QuantileLevels;
    int NanPolicy = 0;

  private:
    vtkUdvrBuildModel(const vtkUdvrBuildModel&) = delete;
    void operator=(const vtkUdvrBuildModel&) = delete;
};

#endif
