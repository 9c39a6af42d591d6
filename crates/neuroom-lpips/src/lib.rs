//! LPIPS, the learned perceptual image distance of Zhang et al. (2018), AlexNet variant: the PSNR / SSIM /
//! LPIPS triple the paper reports for re-rendered panoramas.
