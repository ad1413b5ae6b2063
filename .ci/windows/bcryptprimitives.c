/* A stand-in for Windows' bcryptprimitives.dll, which Wine 8.0 does not have.
 *
 * Windows 8 and later ship bcryptprimitives.dll with ProcessPrng, the system's random number
 * generator; Rust's standard library (so the cryptography package that asyncua imports) links
 * to it. Wine 8.0 has no such DLL, so those extension modules fail to load under Wine only.
 * This one exports ProcessPrng over RtlGenRandom (advapi32's SystemFunction036), which Wine
 * has. It is built by .ci/windows/lane.py into the Windows Python of the Windows lane;
 * nothing of it goes into pyuss or to a Windows machine. docs/windows-lane.md */
#include <windows.h>
#include <ntsecapi.h>

BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T len)
{
    while (len > 0) {
        ULONG chunk = len > 0x10000000 ? 0x10000000 : (ULONG)len;
        if (!RtlGenRandom(data, chunk))
            return FALSE;
        data += chunk;
        len -= chunk;
    }
    return TRUE; /* Windows' ProcessPrng always returns TRUE */
}

BOOL WINAPI DllMain(HINSTANCE instance, DWORD reason, LPVOID reserved)
{
    (void)instance;
    (void)reason;
    (void)reserved;
    return TRUE;
}
